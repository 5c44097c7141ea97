"""What a person looks at besides the reports: a log's standard figures (`plot`, `tiltload plot`) and the Foxglove
layouts of the 3D replay (`foxglove_layout`, `tiltload layout`). docs/master.md."""
