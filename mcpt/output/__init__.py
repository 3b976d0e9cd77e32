"""Results: image files (``image``), their AOV layers (``layers``) and the denoiser (``denoise``)."""
