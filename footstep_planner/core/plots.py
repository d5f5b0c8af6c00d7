"""Pictures of the analysis for a person to look at (matplotlib, imported lazily: it is
not bundled with the extension)."""

from __future__ import annotations

import numpy as np

from .analysis import ClipAnalysis
from .clip import FOOT_NAMES

COLOURS = ("tab:blue", "tab:red")


def plot_clip(a: ClipAnalysis, path: str) -> str:
    """Heel and toe heights, foot speeds, and the contact phases of one clip, like
    Johansen's analysis graphs: bars from strike to liftoff, thin bars from land to lift,
    ticks at the stance times, grey spans for flights (dark for jumps)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = a.motion
    t = m.frame_of(m.times)
    fig, ax = plt.subplots(3, 1, figsize=(12, 7), sharex=True,
                           gridspec_kw={"height_ratios": [3, 2, 1.2]})
    for k in range(2):
        c = COLOURS[k]
        ax[0].plot(t, m.heel[k, :, 2], color=c, label=f"{FOOT_NAMES[k]} heel")
        ax[0].plot(t, m.toe[k, :, 2], color=c, ls="--", label=f"{FOOT_NAMES[k]} toe")
        v = np.linalg.norm(np.gradient(m.toe[k, :, :2], 1.0 / m.fps, axis=0), axis=1)
        ax[1].plot(t, v, color=c, lw=1)
        for st in a.stances:
            if st.foot != k:
                continue
            f = lambda x: float(m.frame_of(x))  # noqa: E731
            ax[2].plot([f(st.strike), f(st.liftoff)], [k, k], color=c, lw=8, solid_capstyle="butt")
            ax[2].plot([f(st.land), f(st.lift)], [k + 0.35, k + 0.35], color=c, lw=3)
            ax[0].axvline(f(st.stance), color=c, lw=0.6, alpha=0.6)
    for x0, x1 in a.flights:
        jump = (x0, x1) in a.jump_flights
        for axis in ax:
            axis.axvspan(float(m.frame_of(x0)), float(m.frame_of(x1)), color="0.5" if jump else "0.85",
                         alpha=0.5, lw=0)
    top = max(0.3, float(np.percentile(np.r_[m.heel[..., 2].ravel(), m.toe[..., 2].ravel()], 98)))
    ax[0].set_ylim(-0.03, top)
    ax[0].set_ylabel("height (m)")
    ax[0].legend(loc="upper right", ncol=4, fontsize=8)
    ax[1].set_ylabel("toe speed (m/s)")
    ax[1].set_ylim(0, 5)
    ax[2].set_yticks([0, 1], list(FOOT_NAMES))
    ax[2].set_ylim(-0.5, 1.7)
    ax[2].set_xlabel("frame")
    cyc = "" if a.cycle is None else f", stride {a.stride:.2f} m, cycle {a.cycle:.2f} s"
    fig.suptitle(f"{a.name}: {a.kind}, {a.gait} ({a.entry_gait} > {a.exit_gait}), "
                 f"{a.speed:.2f} m/s{cyc}, tau {a.tau:+.2f} 1/m")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
