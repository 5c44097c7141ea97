"""The native FMU toolkit: one generic FMI 2.0 co-simulation layer in C, shared by every tiltload FMU.

Each FMU declares its variables once (variables.py); from that table the build writes the
modelDescription.xml and the C tables the generic layer (c/tl_fmi2.c) reads, then compiles the
generic layer, the model's hooks and its CasADi-generated code with the system C compiler.
"""
