"""Session-wide: the default control socket of every daemon a test starts without ``--socket`` is
private to this test session ($XDG_RUNTIME_DIR/rtctl.sock), so a user's daemon, or another test
session on the same machine, never answers for it — or refuses it the path."""
import os
import tempfile

os.environ["XDG_RUNTIME_DIR"] = tempfile.mkdtemp(prefix="rtctl-tests-")
