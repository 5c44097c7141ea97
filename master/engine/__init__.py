"""A generic FMI 2.0 and 3.0 co-simulation engine: it runs any system of co-simulation FMUs and knows nothing of tilt-rotors.

    system            what runs: instances, periods, parameters, connections (JSON), faults
    ssp/              the same as an SSP 1.0 package (export, load); ssp2: SSP 2.0, for FMI 3.0; zip_unpack
    connections       connections resolved and checked against the model descriptions
    model_description reading an FMU's description; values checked against it
    slave             the interface of one FMU instance; fmi2 (FMI 2.0), fmi3 (FMI 3.0): in this process;
                      isolation/: in a worker process or on another machine
    execution         the multirate algorithm: who steps when, inputs from outputs, delay lines
    jacobi            what a Jacobi master (libcosim, Ecos) does to a system, as connection delays
    faults/           faults between outputs and inputs (parse, apply, draw)
    observers         read-only views: metrics, progress; mcap_log: the MCAP logger and readers
    run               one run: execution + logger + metrics, failures as one line

What is specific to a system comes in from the caller: instance names for metrics, derived log
channels (a 3D scene), and the policy of which FMUs run isolated.
"""
