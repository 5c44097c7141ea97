"""The Dask runtime that campaigns and searches share: the scheduler's address (`address`), the cluster (`cluster`),
the dispatch of runs with retries (`dispatch`), the log of Dask's records (`logs`), FMUs shipped to an existing
cluster's workers (`shipping`), what a worker process keeps between runs (`worker`) and how a batch fails to finish
(`errors`). docs/campaigns.md, docs/throughput.md."""
