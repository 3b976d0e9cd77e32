"""The one base class of every error meant for the user.

Library code raises a subclass of :class:`McptError` for anything the user can fix (a bad scene
key, a missing mesh, an image too large for the GL driver, an unwritable output, ...). Its message
is one line that names the file, line and key where there is one. The command line catches this
one class, prints the message and exits with status 2; anything else is a bug.
"""

from __future__ import annotations


class McptError(Exception):
    """A problem the user can fix; ``str(err)`` is one line meant to be printed as is."""
