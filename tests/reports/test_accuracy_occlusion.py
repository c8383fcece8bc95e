"""The accuracy report's ambient-occlusion section (durer.reports.accuracy.occlusion)."""

from __future__ import annotations

import pytest

from durer.reports.accuracy.measure import Config
from durer.reports.accuracy.occlusion import (
    Occlusion,
    OcclusionRow,
    OcclusionSettings,
    markdown_section,
    measure_occlusion,
    settings_for,
)


def test_settings_follow_the_report_mode():
    assert settings_for(Config.full()) == OcclusionSettings((160, 90), (1, 4, 16, 64), 4096)
    assert settings_for(Config.quick_config()) == OcclusionSettings((80, 45), (1, 4, 16), 256)


def test_quick_measurement():
    occlusion = measure_occlusion(Config.quick_config())
    off, *on = occlusion.rows
    assert off.samples is None and off.ao_rays == 0 and off.rmse == occlusion.darkening > 0.01
    assert [r.samples for r in on] == [1, 4, 16]
    hits = on[0].ao_rays
    assert 0.5 * 80 * 45 < hits <= 80 * 45  # one ray per shaded hit; the sky takes none
    assert [r.ao_rays for r in on] == [hits, 4 * hits, 16 * hits]
    # 4x the samples: the error falls by more than the 2x of independent rays.
    assert on[2].rmse < on[1].rmse / 2 < on[0].rmse / 4
    assert all(r.ms > 0 and r.rmse <= r.worst for r in occlusion.rows)
    assert -1.0 < occlusion.slope < -0.55


def test_markdown_section():
    settings = OcclusionSettings((160, 90), (1, 4), 4096)
    rows = [OcclusionRow(None, 10.0, 0, 0.04, 0.1), OcclusionRow(1, 12.0, 14_400, 0.04, 0.12),
            OcclusionRow(4, 20.0, 57_600, 0.01, 0.05)]
    text = "\n".join(markdown_section(Occlusion(settings, 5, 900.0, 0.04, rows)))
    assert "\n## Ambient occlusion\n" in text
    assert "at 160×90" in text and "4096-sample AO render" in text and "median of 5 rounds" in text
    assert "| off | 10.0 | 1.00 | 0.0 | 4.00e-02 | 1.00e-01 |" in text
    assert "| 4 | 20.0 | 2.00 | 4.0 | 1.00e-02 | 5.00e-02 |" in text
    assert "fitted slope -1.00" in text  # 0.04 -> 0.01 from 1 to 4 samples
    assert "each added 174 ns" in text  # 10 ms over 57,600 rays
    assert Occlusion(settings, 5, 900.0, 0.04, rows).slope == pytest.approx(-1.0)
