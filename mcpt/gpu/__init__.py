"""The GPU side: the GL context (``context``, the only module that creates one), buffer textures
(``tbo``), what a scene needs compiled (``features``), packing (``pack``), shader assembly
(``shader``) and the pass loop (``render``)."""
