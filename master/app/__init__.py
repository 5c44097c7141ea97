"""The tiltload application on the engine: the `tiltload` command, the thesis's loop and its ports, the 3D scene,
plots and Foxglove layouts, campaigns, regression (reproduce, compare), and `tiltload wrap`."""
