"""The pictures `inspect --png` draws: selections and the principal stress field."""

from __future__ import annotations

import loadpath.loadcase as lc
import numpy as np
import pytest
from fea_cases import SIGMA_GROSS, open_hole_body, open_hole_case
from loadpath.fea import analyze
from loadpath.fea.plots import draw_field, draw_selectors, save_png
from loadpath.mesh import MeshSize

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")


def test_png_of_selections_and_field(tmp_path):
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

    (rb,) = lc.resolve(open_hole_case(), [open_hole_body(64)])
    a = analyze(rb, size=MeshSize(3.0, 0.6, 1.0))
    out = save_png(tmp_path / "specimen.png", a.field(1.0), rb, 1.0)
    assert out.exists() and not out.with_name(out.name + ".tmp").exists()
    img = mpimg.imread(out)
    assert img.shape[0] > 300 and img.shape[1] > 800
    # the field is drawn: many coloured (not white / grey) pixels on the right half
    right = img[:, img.shape[1] // 2 :, :3]
    coloured = np.ptp(right, axis=2) > 0.2
    assert coloured.mean() > 0.05

    fig, (ax1, ax2) = plt.subplots(1, 2)
    draw_selectors(ax1, rb)
    labels = [t.get_text() for t in ax1.get_legend().get_texts()]
    assert labels == ["clamp", "pull"]
    im = draw_field(ax2, a.field())
    # the colour scale reaches the concentration at the hole (sampled a pixel away from its edge)
    assert 2.5 * SIGMA_GROSS < np.nanmax(im.get_array()) <= np.abs(a.result.stress[:, 0]).max()
    segs = ax2.collections[0].get_segments()
    assert len(segs) > 100
    # far from the hole the segments are horizontal (uniaxial pull along x)
    d = np.array([s[1] - s[0] for s in segs])
    mid = np.array([0.5 * (s[0] + s[1]) for s in segs])
    far = (np.abs(mid[:, 0] - 75) > 30) & (np.abs(mid[:, 0] - 75) < 55)
    assert np.all(np.abs(d[far, 1]) < 0.05 * np.abs(d[far, 0]))
    plt.close(fig)
