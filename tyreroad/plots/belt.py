"""The rolling pass on the flexible belt beside the rigid belt (issue 26, ``results/belt/rolling_spectra.nc``):
1/3-octave levels of the contact force (both belts) and of the belt's velocity ahead of and behind the contact."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

__all__ = ["plot_belt_rolling_spectra"]


def plot_belt_rolling_spectra(ds: xr.Dataset, path) -> None:
    """Two panels per speed: the contact force's levels (rigid and flexible belt) and the belt velocity's."""
    speeds = ds["speed"].values
    fig, axes = plt.subplots(len(speeds), 2, figsize=(10, 3.6 * len(speeds)), squeeze=False)
    f = ds["band"].values
    for row, v in zip(axes, speeds):
        sel = ds.sel(speed=v)
        row[0].semilogx(f, sel["contact_force_level_rigid"].values, "o-", ms=3, label="rigid belt")
        row[0].semilogx(f, sel["contact_force_level_belt"].values, "s-", ms=3, label="flexible belt")
        row[0].set_ylabel("contact force level [dB re 1 N]")
        row[0].set_title(f"{ds.attrs.get('material', '')} at {v:g} m/s: total contact force", fontsize=9)
        for p in ds["belt_point"].values:
            off = float(sel["belt_observation_offset"].sel(belt_point=p)) * 1e3
            row[1].semilogx(f, sel["belt_velocity_level"].sel(belt_point=p).values, "o-", ms=3,
                            label=f"{p} ({off:+.0f} mm from x_c)")
        row[1].set_ylabel("belt velocity level [dB re 5e-8 m/s]")
        row[1].set_title("normal velocity of the belt near the contact", fontsize=9)
        for ax in row:
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize=7)
            ax.set_xlabel("1/3-octave band centre [Hz]")
    fig.tight_layout()
    fig.savefig(path, dpi=130, format="png")
    plt.close(fig)
