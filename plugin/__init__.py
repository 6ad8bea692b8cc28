"""Host-neutral application layer: settings, the pipeline job and the ``loadpath`` command line."""
