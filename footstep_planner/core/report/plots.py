"""Pictures of the analysis for a person to look at (matplotlib, imported lazily: it is
not bundled with the extension)."""

from __future__ import annotations

import numpy as np

from ..clips.analysis import ClipAnalysis
from ..clips.clip import FOOT_NAMES

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


def _save(fig, path: str) -> str:
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_synthesis(report: dict, out_dir: str, name: str = "plan") -> list[str]:
    """The synthesis of a plan as thesis figures 4.3 to 4.5, from a plan report
    (``pipeline.Synthesis.to_dict`` under "synthesis"): the curvature tau (the plan's
    clips in blue, the estimate from the body trajectory in black, the low-passed blend
    parameter in red), the walk/run parameter s with its pins, and a top view of the
    footprints (planned, smoothed, final) and the body trajectory. Returns the PNG paths."""
    import os

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    syn = report.get("synthesis", report)
    cur = syn["curves"]
    first = cur["tau_first"]
    os.makedirs(out_dir, exist_ok=True)
    paths = []

    fig, ax = plt.subplots(figsize=(12, 4))
    ax.plot(first["time"], first["plan"], color="tab:blue", lw=1.2, label="plan's clips")
    ax.plot(first["time"], first["raw"], color="black", lw=0.8, label="estimated from the body trajectory")
    ax.plot(first["time"], first["smoothed"], color="tab:red", lw=2, label="blend parameter (low-passed)")
    ax.axhline(0, color="grey", lw=0.5)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("curvature tau (1/m, + left)")
    ax.set_title(f"{name}: curvature (thesis fig. 4.3/4.4)")
    ax.legend(loc="upper right", fontsize=8)
    paths.append(_save(fig, os.path.join(out_dir, f"{name}_tau.png")))

    fig, ax = plt.subplots(figsize=(12, 3.2))
    ax.plot(cur["u"], cur["s"], color="tab:red", lw=2, label="s (0 walk, 1 run)")
    pins = np.array(cur["speed_pins"], float).reshape(-1, 2)
    ax.plot(pins[:, 0], pins[:, 1], "ko", ms=5, label="pins: start, end, jump entry/exit")
    ax.set_xlabel("footsteps")
    ax.set_ylabel("s")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title(f"{name}: speed blend parameter (thesis fig. 4.5)")
    ax.legend(loc="upper right", fontsize=8)
    paths.append(_save(fig, os.path.join(out_dir, f"{name}_speed.png")))

    fps_ = syn["footprints"]
    fig, ax = plt.subplots(figsize=(9, 9))
    for key, style, label in (("planned", dict(color="0.6", marker="s", ms=4, ls=":"), "planned"),
                              ("smoothed", dict(color="tab:green", marker=".", ms=4, ls=""), "smoothed"),
                              ("position", dict(color="black", marker="o", ms=4, ls=""), "final")):
        p = np.array([f[key] for f in fps_])
        ax.plot(p[:, 0], p[:, 1], label=f"{label} footprints", **style)
    for k, c in zip("LR", COLOURS):
        p = np.array([f["position"] for f in fps_ if f["foot"] == k])
        if len(p):
            ax.plot(p[:, 0], p[:, 1], "o", color=c, ms=3)
    body = np.array(syn["body"]["position"])
    ax.plot(body[:, 0], body[:, 1], color="tab:orange", lw=1.5, label="body trajectory")
    ax.set_aspect("equal")
    ax.set_title(f"{name}: footprints and body trajectory (top view)")
    ax.legend(loc="best", fontsize=8)
    paths.append(_save(fig, os.path.join(out_dir, f"{name}_path.png")))
    return paths
