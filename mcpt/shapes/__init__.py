"""Geometry and acceleration (the build room): mesh import (``mesh``, ``obj``), the median-split
BVH (``bvh``), triangle packing (``geometry``) and the world a scene becomes (``world``)."""
