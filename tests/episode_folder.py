"""A short subretinal episode's run folder, for the view's tests: 1 s of iOCT before the
approach, a 0.2 mm approach, 0.5 s hover, 1 s hold; `hold` compensation, so that the prediction
the controller used at each period is the newest estimate it had received."""

from __future__ import annotations

from pathlib import Path

from rcmplan.cli.subretinal import write_outputs
from rcmplan.subretinal.episode_settings import EpisodeSettings

SHORT = EpisodeSettings(compensation="hold", warmup_s=1.0, start_height_m=200e-6, hover_s=0.5,
                        hold_s=1.0, advance_speed_m_s=0.4e-3)  # fmt: skip


def write_episode(out: Path) -> Path:
    """Run the short episode and write its folder in `out` (made if missing)."""
    out.mkdir(parents=True, exist_ok=True)
    doc = write_outputs(SHORT, out, figures=False)
    assert doc["status"] == "ok", doc["message"]
    return out
