"""Many imaging jobs at once: a YAML plan (:mod:`.plan`) run on a dask cluster (:mod:`.run`)."""
