"""The extra EXR channels (`--aov`) a run can write, by name: the command line offers them
without loading the pipeline, and the pipeline computes them."""

AOV_NAMES = ("optical_depth", "transmittance", "spread", "level", "direct", "scattered", "emission",
             "airlight", "airlight_scattered")
