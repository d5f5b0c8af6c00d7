"""Motion synthesis on the sample scenes with the real CMU library: the Jumps path speeds
up into each leap and slows down after it, turns come out as smooth curvature, and the
synthesized footprints stay on the surfaces."""

import json
from importlib import import_module

import numpy as np
import pytest

from conftest import needs_cmu
from conftest import plan_sample as _plan

pytestmark = needs_cmu


def _synth(fp, name):
    """(scene, the plan, its setup, its synthesis); the plan's footprints are the
    synthesis's path, with both standing feet at either end (as ``planning.plan_and_synthesize``
    gives them)."""
    from dataclasses import replace

    scene, result, setup, goal = _plan(fp, name)
    planning = import_module(fp.__name__ + ".blender.planning")
    syn = planning.synthesize(scene, result, setup)
    return scene, replace(result, footprints=list(syn.plan)), setup, syn


def _supported(fp, setup, pos, head):
    core = import_module(fp.__name__ + ".core.plan.surface")
    pl = setup.planner
    return core.footprint_support(pl.ground, pl.obstacles, pos, head, setup.forward, pl.foot,
                                  core.SupportLimits(clearance=pl.clearance))


@pytest.fixture(scope="module")
def jumps(fp):
    return _synth(fp, "jumps")


def test_jumps_runs_into_each_leap_and_walks_away(fp, jumps):
    scene, result, setup, syn = jumps
    fs = result.footprints
    leaps = [j for j in range(len(fs) - 1) if fs[j + 1].jump]
    assert len(leaps) == 2
    S = syn.final.schedule
    bg = import_module(fp.__name__ + ".core.synth.blend_groups")
    pins_u, pins_s = zip(*syn.speed_pins)
    s_at = lambda u: float(bg.speed_parameter(np.array([u]), pins_u, pins_s, syn.settings.speed_sigma)[0])  # noqa: E731
    np.testing.assert_allclose(syn.s_final, [s_at(u) for u in S.u], atol=1e-9)  # the frames' s
    sigma = syn.settings.speed_sigma
    for j in leaps:
        assert s_at(j) == pytest.approx(1.0) and s_at(j + 1) == pytest.approx(1.0)  # take-off, landing
        if j - sigma > 0 and all(not f.jump for f in fs[max(0, j - 6):j]):
            # speeds up over sigma steps, from a walk (if there was room)
            assert s_at(j - sigma - 0.5) == pytest.approx(0.0)
            assert 0.0 < s_at(j - sigma / 2) < 1.0
    assert s_at(0) == 0.0 and s_at(len(fs) - 1) == 0.0  # walking at both ends
    # the run's clips carry the weight where s = 1, the walk's where s = 0
    run_cols = [i for i, c in enumerate(syn.clips) if c in {x.clip for x in setup.library.turn_groups["run"].clips}]
    loco = S.weights[:, :len(run_cols) + len(setup.library.turn_groups["walk"].clips)]
    live = loco.sum(axis=1) > 1e-3  # (not inside a leap, where the leap clip has it all)
    share = S.weights[live][:, run_cols].sum(axis=1) / loco[live].sum(axis=1)
    np.testing.assert_allclose(share, syn.s_final[live], atol=1e-6)


def test_jumps_weights_footprints_and_frames(fp, jumps):
    scene, result, setup, syn = jumps
    np.testing.assert_allclose(syn.weights.sum(axis=1), 1.0, atol=1e-9)
    for arr in (syn.body_position, syn.body_heading, syn.weights, syn.clip_time, syn.tau_final, syn.s_final):
        assert np.isfinite(arr).all()
    pos, head = syn.footprints
    sup = _supported(fp, setup, pos, head)
    assert sup.ok.all(), [(i, r) for i, r in enumerate(sup.reason) if r]
    np.testing.assert_allclose(pos[:, 2], sup.z, atol=1e-6)  # on the surface
    # the leap clip (or its mirror) plays whole across its step, at full weight
    S = syn.final.schedule
    for j in [j for j in range(len(result.footprints) - 1) if result.footprints[j + 1].jump]:
        leap = syn.clips.index(result.footprints[j + 1].label)
        inside = (S.t >= S.footprint_times[j]) & (S.t <= S.footprint_times[j + 1])
        assert np.all(S.weights[inside, leap] == 1.0)
    # footprints stay near the plan (the synthesis bends the path, it does not reroute it;
    # around a leap the refinement gives the jump its clip's own length back)
    planned = np.array([f.position for f in result.footprints])
    assert np.linalg.norm(pos[:, :2] - planned[:, :2], axis=1).max() < 0.75


def test_turns_curvature_is_smooth_and_in_the_groups_range(fp):
    scene, result, setup, syn = _synth(fp, "turns")
    lo, hi = setup.library.turn_groups["walk"].tau_range()
    tau = syn.tau_final
    assert tau.min() >= lo - 0.5 and tau.max() <= hi + 0.5
    # low-passed: it changes no faster than a turn can (a step's sway is filtered out)
    rate = np.abs(np.diff(tau)) * syn.final.schedule.fps
    assert rate.max() < 1.5  # 1/m per second
    assert np.abs(syn.tau).max() > 0.3  # and the path's bends are there
    assert np.all(syn.s_final == 0.0)  # no jump: it walks all the way
    pos, head = syn.footprints
    assert _supported(fp, setup, pos, head).ok.all()


def test_obstacles_footprints_keep_to_the_step_and_clear_the_pillars(fp):
    scene, result, setup, syn = _synth(fp, "obstacles")
    pos, head = syn.footprints
    sup = _supported(fp, setup, pos, head)
    assert sup.ok.all(), [(i, r) for i, r in enumerate(sup.reason) if r]
    assert pos[-1, 2] == pytest.approx(0.15, abs=1e-3)  # up on the step
    body = syn.body_position
    assert body[-1, 2] == pytest.approx(0.15, abs=0.03)  # and the body with it


def test_plan_report_and_plot_verb(fp, jumps, tmp_path, capsys):
    scene, result, setup, syn = jumps
    cli = import_module(fp.__name__ + ".blender.command.cli")
    doc = import_module(fp.__name__ + ".core.report.document").plan_report(result, syn, "CMU", [0, 0, 0], 1.0)
    path = tmp_path / "jumps.json"
    path.write_text(json.dumps(doc))
    assert {"smoothing_ms", "refinement_ms", "body_trajectory_ms", "blend_groups_ms", "frames",
            "footprints"} <= set(doc["stages"])
    capsys.readouterr()
    assert cli.cli_main(["plot", str(path), "--out", str(tmp_path / "plots")]) == 0
    out = capsys.readouterr().out.split()
    assert [p.rsplit("_", 1)[-1] for p in out] == ["tau.png", "speed.png", "path.png"]
    for p in out:
        with open(p, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    (tmp_path / "bad.json").write_text("{}")
    assert cli.cli_main(["plot", str(tmp_path / "bad.json"), "--out", str(tmp_path)]) == 2
    assert "not a plan report" in capsys.readouterr().err
