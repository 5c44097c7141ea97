"""The tick loop in C: the kernel (tl_loop.c, compiled on first use by kernel.py), and the execution's plan for it
(loop.py, a clocked FMU's part in clocks.py, the faults' part in fault_plan.py); the codes C and Python share, declared
once in tl_codes.h (codes.py reads them), and the structs' layout, exported by tl_layout.c and checked when the kernel
is loaded (layout.py)."""
