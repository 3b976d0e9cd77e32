"""Shading concepts, each the host twin of the GLSL file of the same name: ``camera``,
``materials``, ``lights``, ``normals``, ``texture`` and ``sampler`` (random numbers)."""
