"""Results: image files (``image``) and the statistics to compare renders (``stats``)."""
