"""The tutorial's numbers are measured: recompute the acquisition figures and find them on the page."""

from __future__ import annotations

import importlib.util

from .conftest import REPO


def _tutorial_module():
    spec = importlib.util.spec_from_file_location("tutorial_script", REPO / "scripts" / "tutorial.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_tutorial_shows_the_numbers_the_library_computes():
    a = _tutorial_module().acquisition_numbers()
    page = " ".join((REPO / "docs" / "tutorial.md").read_text().split())  # line breaks do not matter
    for text in (f"range {a['resolution_range_m']:.3f} m", f"cross-range {a['resolution_cross_m']:.3f} m",
                 f"range {a['radius_range_m']:.1f} m", f"by {a['defocus_rad']:.2f} rad",
                 f"{a['taylor_widening_pct']:.0f} % wider", f"here {a['irw_range_m']:.3f} m predicted in range",
                 f"calls IRW is {a['irw_factor']:.3f} of it"):
        assert text in page, f"docs/tutorial.md is stale ({text!r} not found): run make tutorial"
    # the Taylor 4/-35 dB window widens the main lobe by about a third, not the 18 % once typed here
    assert 30 < a["taylor_widening_pct"] < 40
