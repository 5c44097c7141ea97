"""The tick loop in C: the kernel (tl_loop.c, compiled on first use), and the execution's plan for it (loop.py)."""
