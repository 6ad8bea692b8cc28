"""Test only: make one stage of a real loadpath run fail, in a process the test cannot reach.

The Cura plugin runs ``loadpath run`` as a child of Cura's Python and the service runs each request
in a child of its forkserver, so the forced-failure tests of those front ends cannot monkeypatch in
their own process.  This folder goes on ``PYTHONPATH`` with ``LOADPATH_TEST_FAULT`` naming a file;
every Python started with it (and every process forked from one) imports this module, which wraps
the real functions of each stage below.  A wrapper reads the file at each call and fails only when
the file names its stage, so one running service serves every stage.  Cura's own Python has no
loadpath: there the module does nothing.

Stages (the ones ``tests/plugin/test_honest.py`` forces in-process):

``splice``        :func:`loadpath.pipeline.splice` raises ValueError("forced failure");
``check``         :func:`loadpath.pipeline.check_output` raises it;
``rename``        ``os.replace`` of the output's temporary file (``.NAME.xxxxxxxx.tmp`` -> ``NAME``,
                  :func:`loadpath.plugin.job.write_atomic`) raises ENOSPC (the cache's go through);
``metrics``       the report's metrics (``loadpath.report.layers._metrics``) raise ValueError;
``report_files``  writing the report writes its first file, then raises ENOSPC.
"""

import os

FAULT = os.environ.get("LOADPATH_TEST_FAULT", "")


def _on(stage):
    try:
        with open(FAULT, encoding="utf-8") as fh:
            return fh.read().strip() == stage
    except OSError:
        return False


def _boom(stage, real):
    def wrapper(*args, **kwargs):
        if _on(stage):
            raise ValueError("forced failure")
        return real(*args, **kwargs)

    return wrapper


def _install():
    import errno
    import re

    import loadpath.pipeline as pipeline
    import loadpath.report as report
    import loadpath.report.layers as layers

    pipeline.splice = _boom("splice", pipeline.splice)
    pipeline.check_output = _boom("check", pipeline.check_output)
    layers._metrics = _boom("metrics", layers._metrics)

    real_replace = os.replace

    def replace(src, dst, *args, **kwargs):
        temp = re.compile(r"\.%s\.[0-9a-f]{8}\.tmp" % re.escape(os.path.basename(os.fspath(dst))))
        if _on("rename") and temp.fullmatch(os.path.basename(os.fspath(src))):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_replace(src, dst, *args, **kwargs)

    os.replace = replace

    real_write = report.Report.write

    def write(self, directory):
        if not _on("report_files"):
            return real_write(self, directory)
        os.makedirs(directory, exist_ok=True)
        name, text = next(iter(self.files.items()))
        with open(os.path.join(directory, name), "w", encoding="utf-8") as fh:
            fh.write(text)
        raise OSError(errno.ENOSPC, "No space left on device")

    report.Report.write = write


if FAULT:
    try:
        import loadpath  # noqa: F401
    except ImportError:  # Cura's Python (the plugin never imports loadpath)
        pass
    else:
        _install()
