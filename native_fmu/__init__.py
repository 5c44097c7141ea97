"""The native FMU toolkit: the generic FMI 2.0 and 3.0 co-simulation layers in C, shared by every tiltload FMU.

Each FMU declares its variables once (variables.py); from that table the build writes the
modelDescription.xml and the C tables the layers' core (c/tl_core.c) reads, then compiles the core,
the version's layer (c/tl_fmi2.c or c/tl_fmi3.c), the model's hooks and its CasADi-generated code
with the system C compiler.
"""
