"""Example scenes, shipped as package data (mcpt.scene.shipped finds them)."""
