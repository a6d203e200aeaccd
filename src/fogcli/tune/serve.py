"""`fogcli tune`'s server in the foreground: bound to 127.0.0.1 only, a random token in
the printed URL, ended by Ctrl-C (uvicorn's own handling of it, for this process only)."""
from __future__ import annotations

import secrets
import socket

from fogcli.errors import UserError
from fogcli.tune.page_app import PageApp
from fogcli.tune.session import Session


def bind(port: int) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind(("127.0.0.1", port))
    except OSError as exc:
        sock.close()
        raise UserError(f"--port {port}: cannot listen on 127.0.0.1 ({exc.strerror})") from None
    sock.listen(16)
    return sock


def require_server():
    """uvicorn (the tune extra), asked for before the image is read."""
    try:
        import uvicorn
    except ImportError:
        raise UserError("fogcli tune needs its web server: pip install 'fogcli[tune]'") from None
    return uvicorn


def serve(session: Session, port: int = 0, open_browser: bool = True, echo=print, token: str | None = None) -> None:
    uvicorn = require_server()
    sock = bind(port)
    port = sock.getsockname()[1]
    token = token or secrets.token_urlsafe(24)
    url = f"http://127.0.0.1:{port}/?token={token}"
    app = PageApp(session, token, port, echo)
    echo(f"fogcli tune: {url}")
    echo("  (Ctrl-C ends it; Save writes " f"{session.yaml_path.name} and {session.output_path.name})")
    if open_browser:
        import webbrowser

        webbrowser.open(url)
    server = uvicorn.Server(uvicorn.Config(app, lifespan="off", log_level="warning", access_log=False))
    try:
        server.run(sockets=[sock])
    except KeyboardInterrupt:       # uvicorn hands Ctrl-C on once it has shut down: here it is the way out
        echo("fogcli tune: stopped")
    finally:
        app.pool.shutdown(wait=True)
        sock.close()
