"""A generic FMI 2.0 and 3.0 co-simulation engine: it runs any system of co-simulation FMUs and knows nothing of tilt-rotors.

Grouped by concept (docs/architecture.md lists every module):

    system            what runs: instances, periods, parameters, connections (JSON), faults
    connections       connections resolved and checked against the model descriptions
    execution         the multirate algorithm: who steps when, inputs from outputs, delay lines; jacobi: what a
                      Jacobi master (libcosim, Ecos) does to a system, as connection delays
    lifecycle, run    the one run life cycle (RunPlan, ExecutionPool); run_system: one plan on an execution of its own
    observers         read-only views: metrics, progress; realtime: the pacer; snapshot: the state to a file and back
    tubes, user_files tolerance tubes; every file a user hands in, bounded before it is read; errors
    fmi/              one FMU in this process: model_description, slave, fmi2, fmi3, fmi3_scheduled, in_process.load,
                      the FMU on disk (binaries, fmu_cache, extraction, pythonfmu_guard)
    isolation/        FMUs hosted in a worker process or on another machine
    log/              the MCAP log: logger, writer, encoding, reader, provenance
    requirement/      requirements over logged signals: files, check, observer, and stl/ (Signal Temporal Logic)
    ssp/              SSP 1.0 and 2.0 packages (export, ssp2, load, schema, zip_unpack)
    faults/           faults between outputs and inputs (schedule, parse, apply, draw)
    native/           the tick loop in C and its plan

What is specific to a system comes in from the caller: instance names for metrics, derived log
channels (a 3D scene), and the policy of which FMUs run isolated. No command line is parsed here:
master/command_line/ does that.
"""
