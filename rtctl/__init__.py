"""rtctl: a real-time control runtime for robot joints."""
from rtctl import kernel_cache as _kernel_cache

_kernel_cache.select()  # before any module defines a kernel: see rtctl.kernel_cache
