"""The page of `fogcli tune` as a plain ASGI app: a static page and a small JSON API over a
Session. A local page is still a server: every request must carry the token printed with
the URL, name this server in Host (no DNS rebinding) and come from its own origin (no
cross-site request); no request names a file: the page reads and writes only the image
named on the command line and its outputs, whose paths the Session fixed."""
from __future__ import annotations

import asyncio
import hmac
import json
from concurrent.futures import ThreadPoolExecutor
from importlib import resources
from urllib.parse import parse_qs

from fogcli.errors import ProcessingError, UserError
from fogcli.tune.session import SHOWN, Session, encode

MAX_BODY = 1 << 20          # a config is a few kB
STATIC = {"/": ("tune.html", "text/html; charset=utf-8"), "/tune.js": ("tune.js", "text/javascript; charset=utf-8"),
          "/tune.css": ("tune.css", "text/css; charset=utf-8")}


def allowed(headers: dict, query: dict, token: str, port: int, method: str) -> str | None:
    """Why a request is refused, or None. headers: lower-case names; query: parse_qs's."""
    hosts = {f"127.0.0.1:{port}", f"localhost:{port}"}
    if headers.get("host") not in hosts:
        return "foreign Host"
    origin = headers.get("origin")
    if origin is not None and origin not in {f"http://{h}" for h in hosts}:
        return "foreign Origin"
    if headers.get("sec-fetch-site") == "cross-site":
        return "cross-site request"
    given = headers.get("x-fogcli-token") or (query.get("token", [""])[0] if method == "GET" else "")
    if not hmac.compare_digest(given.encode(), token.encode()):
        return "no valid token"
    return None


class PageApp:
    def __init__(self, session: Session, token: str, port: int, echo=print):
        self.session, self.token, self.port, self.echo = session, token, port, echo
        # the device's work on one thread of this process, off the event loop
        self.pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="fogcli-render")

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        method, path = scope["method"], scope["path"]
        why = allowed(headers, query, self.token, self.port, method)
        if why:
            return await _send(send, 403, f"refused: {why}\n".encode(), "text/plain")
        body = b""
        while True:
            msg = await receive()
            body += msg.get("body", b"")
            if len(body) > MAX_BODY:
                return await _send(send, 413, b"too large\n", "text/plain")
            if not msg.get("more_body"):
                break
        try:
            status, data, kind, extra = await self.route(method, path, query, body)
        except UserError as exc:
            status, data, kind, extra = 400, json.dumps({"error": str(exc)}).encode(), "application/json", {}
        except (ValueError, TypeError, KeyError) as exc:
            status, data, kind, extra = 400, json.dumps({"error": f"bad request: {exc}"}).encode(), "application/json", {}
        except Exception as exc:        # a full disk on Save, a device error: one line, here and on the page
            msg = f"{exc.__class__.__name__}: {exc}" if not isinstance(exc, (OSError, ProcessingError)) else str(exc)
            self.echo(f"fogcli tune: {method} {path}: {msg}")
            status, data, kind, extra = 500, json.dumps({"error": msg}).encode(), "application/json", {}
        await _send(send, status, data, kind, extra)

    async def route(self, method: str, path: str, query: dict, body: bytes):
        s = self.session
        if method == "GET" and path in STATIC:
            name, kind = STATIC[path]
            data = resources.files("fogcli.tune").joinpath("page", name).read_bytes()
            # the page's own links carry the token, as its first address did
            return 200, data.replace(b"{{TOKEN}}", self.token.encode()), kind, {}
        if method == "GET" and path == "/api/state":
            return _json(s.state())
        if method == "GET" and path == "/api/image":
            which, size = query.get("which", ["input"])[0], query.get("size", ["preview"])[0]
            exposure = float(query.get("exposure", ["0"])[0])
            return await self.run(lambda: self.image(which, size, exposure))
        if method == "GET" and path == "/api/pixel":
            return _json(s.pixel(float(query["x"][0]), float(query["y"][0])))
        if method != "POST":
            return 404, b"not found\n", "text/plain", {}
        req = json.loads(body or b"{}")
        if not isinstance(req, dict):
            raise UserError("expected a JSON object")
        if path == "/api/render":
            return await self.run(lambda: self.render(req))
        if path == "/api/light":
            return _json(s.light_at(float(req["x"]), float(req["y"])))
        if path == "/api/preset":
            s.set_preset(str(req["name"]))
            return _json(s.state())
        if path == "/api/save":
            saved = await self.run(lambda: s.save(_overrides(req)))
            self.echo(f"fogcli tune: saved {saved['yaml']} and {saved['output']}; the same frame: {saved['command']}")
            return _json(saved)
        return 404, b"not found\n", "text/plain", {}

    async def run(self, fn):
        return await asyncio.get_running_loop().run_in_executor(self.pool, fn)

    def render(self, req: dict):
        size = req.get("size", "preview")
        if size not in ("preview", "full"):
            raise UserError(f"size: expected preview or full, got {size!r}")
        show = req.get("show", "output")
        r = self.session.render(_overrides(req), size, aovs=show in ("scattered", "airlight"))
        return self.image(show, size, float(req.get("exposure", 0.0)), r.ms)

    def image(self, which: str, size: str, exposure: float, ms: float | None = None):
        if which not in SHOWN:
            raise UserError(f"which: expected one of {', '.join(SHOWN)}, got {which!r}")
        s = self.session
        r = s.full if size == "full" else s.preview
        if which == "input":
            plane = (s.big if size == "full" else s.small).rgb
        elif r is None:
            raise UserError(f"no {size} frame rendered yet")
        elif which not in r.planes:
            plane = s.aovs(size)[which]
        else:
            plane = r.planes[which]
        extra = {"x-render-ms": f"{ms:.1f}"} if ms is not None else {}
        # a preview lives for a tenth of a second: a lighter JPEG, quicker made and decoded
        quality = 85 if size == "preview" else 95
        return 200, encode(plane, max(-20.0, min(20.0, exposure)), quality), "image/jpeg", extra


def _overrides(req: dict) -> dict:
    o = req.get("overrides", {})
    if not isinstance(o, dict):
        raise UserError("overrides: expected a mapping of config sections")
    return o


def _json(data) -> tuple:
    return 200, json.dumps(data).encode(), "application/json", {}


async def _send(send, status: int, data: bytes, kind: str, extra: dict | None = None) -> None:
    headers = [(b"content-type", kind.encode()), (b"content-length", str(len(data)).encode()),
               (b"cache-control", b"no-store"), (b"x-content-type-options", b"nosniff"),
               (b"referrer-policy", b"no-referrer"),
               (b"content-security-policy", b"default-src 'self'; img-src 'self' blob: data:; frame-ancestors 'none'")]
    headers += [(k.encode(), v.encode()) for k, v in (extra or {}).items()]
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": data})
