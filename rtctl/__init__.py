"""rtctl: a real-time control runtime for robot joints."""
import sys as _sys

from rtctl import kernel_cache as _kernel_cache

# The kernel directory is chosen just before numba is first imported (see rtctl.kernel_cache):
# a process that never compiles — the e-stop client — never pays for hashing the sources.
if "numba" in _sys.modules:
    _kernel_cache.select()
else:
    _sys.meta_path.insert(0, _kernel_cache.SelectBeforeNumba)
