"""mcpt: a Monte Carlo path tracer on headless OpenGL (GLSL fragment shaders, TBOs, moderngl)."""

__version__ = "0.1.0"
