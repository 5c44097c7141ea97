"""The controller+estimator FMU of the thesis (ch. 3-4), in three parts:

    design/     the controllers' design: error dynamics with integral action, weights, DLQR, the LMI
                syntheses (mixed H2/H-infinity with pole regions), feedforward (3.18), the estimators'
                matrices (estimator_setup), the design cache and artifacts
    reference/  numpy reference implementations: the oracle the FMU's C is tested against (LKF, ZSE,
                the controller's run-time step) and design-time tools (zonotopes, closed-loop simulation)
    fmu/        the FMU itself: its variable table (fmu_variables), its C (law, LKF, ZSE), its build recipe
"""
