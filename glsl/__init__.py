"""Shaders, shipped as package data (mcpt/gpu/shader.py assembles them)."""
