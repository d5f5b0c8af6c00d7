"""IK and bake (thesis 3.8, 3.9) on the sample scenes with the CMU library: stage times in
the layout of the thesis's Table 4.1, the quality of the baked result, and the thesis's
claim measured side by side: our decoupled IK (body offset, then each leg in closed form)
against a conjugate-gradient IK over all the legs' degrees of freedom and the body (as in
Choi et al. 2003, with scipy.optimize), on the same synthesized path.

    .venv/bin/python benchmarks/bench_ik_bake.py [--scenes jumps,turns,obstacles] [--cg-frames 300]
        [--library cmu|mannequin]

``--library mannequin`` runs it with the project's own sample character and its generated
clips (no outside data).

Targets (issue 5): foot skate under 2 mm mean and 10 mm max per stance; planted foot
within 1 cm of its footprint; no penetration deeper than 5 mm; goal within 5 cm; IK under
0.05 ms per frame; a bake of 1400 frames under 0.5 s.
"""

import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
from library import MOCAP, cmu_files  # noqa: E402  (benchmarks/library.py: the CMU library)



def cg_ik(rig, basis, t, body_pos, body_yaw, targets, max_frames=None):
    """Choi et al. 2003's way, per frame: minimise over the body offset (x, y, z, yaw)
    and each leg's thigh (3), knee (1) and foot (3) rotations the squared distance of
    each planted foot from its target pose, plus a small pull towards the clip's pose,
    with scipy's conjugate gradient (numerical gradients), warm-started from the frame
    before. Returns (bases, body_pos, body_yaw, seconds, frames solved)."""
    from scipy.optimize import minimize
    from scipy.spatial.transform import Rotation

    from footstep_planner.core.solve.ik import body_frames
    from footstep_planner.core.clips.rig import forward_kinematics

    F = len(t)
    pose = forward_kinematics(rig, basis)
    chains = []
    for side in ("l", "r"):
        th, sh = rig.role_index(f"thigh_{side}"), rig.role_index(f"shin_{side}")
        fo = rig.foot_chain(side)[0]
        chains.append((th, sh, fo))
    out = basis.copy()
    bp, by = body_pos.copy(), body_yaw.copy()
    x = np.zeros(4 + 14)
    frames = np.flatnonzero(targets.weight.max(axis=0) >= 1)
    if max_frames:
        frames = frames[:max_frames]
    t0 = time.perf_counter()

    def legs(f, x):
        B = body_frames((body_pos[f] + x[:3])[None], np.array([body_yaw[f] + x[3]]))[0]
        res = []
        for k, (th, sh, fo) in enumerate(chains):
            v = x[4 + 7 * k:4 + 7 * (k + 1)]
            parent = pose[f, rig.parents[th]]
            bt = basis[f, th].copy()
            bt[:3, :3] = Rotation.from_rotvec(v[:3]).as_matrix() @ bt[:3, :3]
            bs = basis[f, sh].copy()
            bs[:3, :3] = Rotation.from_rotvec([v[3], 0, 0]).as_matrix() @ bs[:3, :3]
            bf = basis[f, fo].copy()
            bf[:3, :3] = Rotation.from_rotvec(v[4:7]).as_matrix() @ bf[:3, :3]
            Mt = parent @ rig.rest_rel[th] @ bt
            Ms = Mt @ rig.rest_rel[sh] @ bs
            Mf = Ms @ rig.rest_rel[fo] @ bf
            res.append((B @ Mf, (bt, bs, bf)))
        return res

    for f in frames:
        planted = targets.weight[:, f] >= 1

        def cost(x):
            c = 1e-3 * float(x @ x)
            for k, (M, _) in enumerate(legs(f, x)):
                if planted[k]:
                    c += float(np.sum((M[:3, 3] - targets.ankle[k, f]) ** 2))
                    c += 0.01 * float(np.sum((M[:3, :3] - targets.foot_rot[k, f]) ** 2))
            return c

        x = minimize(cost, x, method="CG", options={"maxiter": 60, "gtol": 1e-7}).x
        for k, (_, (bt, bs, bf)) in enumerate(legs(f, x)):
            th, sh, fo = chains[k]
            out[f, th], out[f, sh], out[f, fo] = bt, bs, bf
        bp[f] += x[:3]
        by[f] += x[3]
    return out, bp, by, time.perf_counter() - t0, len(frames)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--mocap", default=MOCAP)
    ap.add_argument("--scenes", default="jumps,turns,obstacles")
    ap.add_argument("--cg-frames", type=int, default=300, help="frames the CG IK solves (it is slow)")
    ap.add_argument("--library", choices=("cmu", "mannequin"), default="cmu",
                    help="the CMU subject-16 clips, or the Footstep Mannequin's generated clips")
    args = ap.parse_args()
    import bpy

    from footstep_planner import register
    from footstep_planner.blender.write import bake as baking
    from footstep_planner.blender import planning
    from footstep_planner.core.solve.frames import body_spin
    from footstep_planner.blender.read.clips import import_clips
    from footstep_planner.blender.sample.sample_scenes import build
    from footstep_planner.core.solve.ik import body_frames, solve_ik
    from footstep_planner.core.solve.targets import BodyMotion, FootPoints, Footprints
    from footstep_planner.core.report.metrics import foot_skate, footprint_error
    from footstep_planner.core.solve.pose import blend_pose, pose_bases
    from footstep_planner.core.clips.rig import forward_kinematics
    from footstep_planner.core.plan.surface import SupportLimits, footprint_support

    from footstep_planner.blender.sample import mannequin
    register()
    files = (cmu_files(args.mocap)
             if args.library == "cmu" else [])
    rows, cmp_rows, parts = [], [], []
    for name in args.scenes.split(","):
        bpy.ops.wm.read_homefile(use_empty=True)
        scene = build(name)
        scene.render.fps = 30
        if args.library == "cmu":
            ob, _ = import_clips(files, name="CMU")
        else:
            ob, _ = mannequin.add_to_scene(scene, "Start")
        if ob.animation_data:
            ob.animation_data.action = None
        goal = np.array(scene.objects["Goal"].location)
        doc = planning.run(scene, ob, goal, start_marker=scene.objects["Start"], name=name, frame_start=1)
        rows.append((name, doc))

        # the same path, IK both ways, quality on the arrays by the same measure
        result, s = planning.plan(scene, ob, goal, None, scene.objects["Start"])
        syn = planning.synthesize(scene, result, s, goal=goal)
        sched = syn.final.schedule
        quat, hips = blend_pose(sched, syn.tracks)
        basis = pose_bases(s.rig, quat, hips)
        pos, head = syn.footprints
        pl = s.planner
        sup = footprint_support(pl.ground, pl.obstacles, pos, head, s.forward, pl.foot,
                                SupportLimits(clearance=pl.clearance))
        normal = np.where(np.isfinite(sup.normal), sup.normal, [0.0, 0.0, 1.0])
        walk = next(a for a in s.analyses if a.kind == "cycle").motion
        spin = body_spin(s.forward, s.analyses)
        planted = syn.planted()
        t0 = time.perf_counter()
        ik = solve_ik(s.rig, basis, BodyMotion(sched.t, syn.body_position, syn.body_heading, spin),
                      FootPoints(walk.heel_local, walk.toe_local), Footprints(sched.feet, planted, pos, head, normal),
                      s.forward)
        t_ours = time.perf_counter() - t0
        yaw0 = spin + syn.body_heading
        cg_basis, cg_pos, cg_yaw, t_cg, n_cg = cg_ik(s.rig, basis, sched.t, syn.body_position, yaw0, ik.targets,
                                                     args.cg_frames)
        fps = 30.0
        stances = [{"foot": int(sched.feet[i]), "start": int(np.ceil(a * fps - 1e-6)),
                    "end": min(int(np.floor(b * fps + 1e-6)), sched.n - 1), "stance": int(round(m * fps)),
                    "position": pos[i], "heading": float(head[i])} for i, (a, m, b) in enumerate(planted)]
        last = max(np.flatnonzero(ik.targets.weight.max(axis=0) >= 1)[:args.cg_frames]) if args.cg_frames else sched.n
        stances = [st for st in stances if st["end"] <= last]

        def measure(bases, bpos, byaw):
            w = body_frames(bpos, byaw)[:, None] @ forward_kinematics(s.rig, bases)
            feet = [s.rig.foot_chain(x)[0] for x in ("l", "r")]
            heel = np.stack([(w[:, f] @ walk.heel_local[k])[:, :3] for k, f in enumerate(feet)])
            toe = np.stack([(w[:, f] @ walk.toe_local[k])[:, :3] for k, f in enumerate(feet)])
            return foot_skate(heel, toe, stances), footprint_error(heel, toe, stances)

        ours = measure(ik.basis, ik.body_pos, spin + ik.body_heading)
        theirs = measure(cg_basis, cg_pos, cg_yaw)
        cmp_rows.append((name, sched.n, t_ours, n_cg, t_cg, ours, theirs))
        parts.append((name, sched.n, ik.seconds))

    print(f"IK and bake ({args.library} library): stage times (ms), thesis Table 4.1 layout")
    head = (f"{'scene':10s} {'footprints':>10s} {'frames':>7s} {'smooth':>7s} {'refine':>7s} {'body':>7s} "
            f"{'blend':>7s} {'pose':>7s} {'IK':>7s} {'IK/frame':>9s} {'bake':>7s} {'total':>7s}")
    print(head + "\n" + "-" * len(head))
    for name, doc in rows:
        st = doc["stages"]
        total = st["synthesis_ms"]
        print(f"{name:10s} {st['footprints']:10d} {st['frames']:7d} {st['smoothing_ms']:7.1f} "
              f"{st['refinement_ms']:7.1f} {st['body_trajectory_ms']:7.1f} {st['blend_groups_ms']:7.1f} "
              f"{st['pose_blend_ms']:7.1f} {st['ik_ms']:7.1f} {st['ik_ms'] / st['frames']:9.4f} {st['bake_ms']:7.1f} {total:7.1f}")
    print("thesis (C#, i7-4790K): jumps 51 fp 1384 frames, IK 159 ms (0.115 ms/frame), total 204 ms; "
          "turns 43 fp 1314 frames, IK 185 ms, total 248 ms")
    print("\nquality of the baked result (the scene as Blender plays it, through the depsgraph)")
    head = (f"{'scene':10s} {'skate mean':>10s} {'skate max':>10s} {'fp err max':>10s} {'penetr.':>8s} "
            f"{'float':>6s} {'goal cm':>8s} {'pops made':>9s} {'worst over clip':>15s}")
    print(head + "\n" + "-" * len(head))
    for name, doc in rows:
        q = doc["quality"]
        intro = q["pops"]["introduced"]
        print(f"{name:10s} {q['foot_skate']['mean_mm']:10.2f} {q['foot_skate']['max_mm']:10.2f} "
              f"{q['footprint_error']['max_mm']:10.2f} {q['penetration']['max_mm']:8.2f} "
              f"{q['floating']['max_mm']:6.2f} {q['goal']['distance_m'] * 100:8.1f} {intro['count']:9d} "
              f"{intro['max_excess_deg']:12.1f} deg")
    print("\nour IK against a conjugate-gradient IK over all the legs' DOF and the body (Choi et al. 2003)")
    head = (f"{'scene':10s} {'ours ms/frame':>13s} {'CG ms/frame':>12s} {'ratio':>7s} {'ours skate max':>15s} "
            f"{'CG skate max':>13s} {'ours fp err':>12s} {'CG fp err':>10s}")
    print(head + "\n" + "-" * len(head))
    for name, n, t_o, n_cg, t_cg, ours, theirs in cmp_rows:
        po, pc = t_o * 1e3 / n, t_cg * 1e3 / max(n_cg, 1)
        print(f"{name:10s} {po:13.4f} {pc:12.2f} {pc / po:7.0f} {ours[0]['max_mm']:15.2f} {theirs[0]['max_mm']:13.2f} "
              f"{ours[1]['max_mm']:12.2f} {theirs[1]['max_mm']:10.2f}")
    print(f"(CG IK on the first {args.cg_frames} planted frames of each path; quality over the stances inside them; "
          "mm)")
    print("\nour IK's parts (ms a frame): the feet's targets, the body offsets (3.8.1), the hips lowered for reach, "
          "the legs (3.8.2)")
    head = f"{'scene':10s} {'targets':>8s} {'offsets':>8s} {'reach':>8s} {'legs':>8s} {'total':>8s}"
    print(head + "\n" + "-" * len(head))
    for name, n, sec in parts:
        print(f"{name:10s} " + " ".join(f"{sec.get(k, 0.0) * 1e3 / n:8.4f}"
                                        for k in ("targets", "body_offset", "reach", "legs", "total")))
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    del baking


if __name__ == "__main__":
    main()
