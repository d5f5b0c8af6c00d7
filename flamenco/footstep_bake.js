// SPDX-License-Identifier: GPL-3.0-or-later
//
// Flamenco 3 job type "Footstep Bake": one Footstep Planner job list (JOBS.json) becomes
// one Blender task per job, each running
//
//     {blender} {blenderArgs} SCENE.blend -c footstep bake --character ... --out ... --report ...
//
// with exactly the arguments `core.jobs.job_argv` builds for that job (Python), so a job
// bakes on a Flamenco worker as it bakes in `bake --job` or on Ray. Install: copy this
// file into the `scripts/` folder beside the flamenco-manager executable and restart the
// Manager. The workers' Blender needs the Footstep Planner extension installed and enabled.
// tests/test_flamenco.py compiles a sample job list with node (flamenco/check_job_type.js).

const JOB_TYPE = {
    label: "Footstep Bake",
    description: "Bake a Footstep Planner job list: one Blender task per job, each saving its baked " +
        "scene and its report in the output folder",
    settings: [
        { key: "jobs_file", type: "string", subtype: "file_path", required: false, visible: "submission",
          description: "The job list (JOBS.json) on this computer, read when the job is submitted" },
        { key: "jobs", type: "string", required: true, visible: "web",
          eval: "Path(bpy.path.abspath(settings.jobs_file)).read_text(encoding='utf-8') if settings.jobs_file else ''",
          description: "The job list's JSON text: [{\"character\": ..., \"goal\": ..., ...}, ...]" },
        { key: "output_folder", type: "string", subtype: "dir_path", required: true, visible: "submission",
          description: "Where each job saves its scene (SCENE_N.blend) and report (SCENE_N.json), unless " +
              "the job names its own \"out\" and \"report\" (relative to this folder)" },
        { key: "markers", type: "bool", default: false, visible: "submission",
          description: "Add a timeline marker at each footstep" },
        { key: "keep_frame_range", type: "bool", default: false, visible: "submission",
          description: "Leave each scene's frame range as it is (by default it grows to cover the bake)" },
        { key: "body_on", type: "string", choices: ["object", "root"], default: "object", visible: "submission",
          description: "Key the body on the armature object or on the rig's root bone (a job's own body_on wins)" },
        { key: "traversable", type: "string", default: "", visible: "submission",
          description: "Traversable objects, comma-separated (default: the scene's tags)" },
        { key: "obstacles", type: "string", default: "", visible: "submission",
          description: "Obstacle objects, comma-separated (default: the scene's tags)" },
        { key: "set", type: "string", default: "", visible: "submission",
          description: "Settings for every job, NAME=VALUE separated by spaces (a job's own settings follow)" },
        // Set by the Flamenco add-on to the submitted copy of the current file:
        { key: "blendfile", type: "string", required: true, visible: "web",
          description: "The scene file every job bakes a copy of" },
    ],
};

// The fields a job may have (core/jobs.py JOB_FIELDS) and the frame limit (MAX_FRAME).
const JOB_FIELDS = ["character", "goal", "start", "name", "report", "out", "frame_start", "goal_heading",
    "body_on", "via", "settings"];
const MAX_FRAME = 1000000;

function compileJob(job) {
    const settings = job.settings;
    const jobs = readJobs(settings.jobs);
    const common = {
        markers: !!settings.markers,
        keep_frame_range: !!settings.keep_frame_range,
        body_on: settings.body_on || "object",
        traversable: settings.traversable || "",
        obstacles: settings.obstacles || "",
        set: splitPairs(settings.set),
    };
    const folder = settings.output_folder;
    const stem = path.stem(settings.blendfile).replace(".flamenco", "");
    for (let i = 0; i < jobs.length; i++) {
        const n = i + 1;
        const entry = jobs[i];
        const out = inFolder(folder, entry.out) || path.join(folder, `${stem}_${n}.blend`);
        const report = inFolder(folder, entry.report) || path.join(folder, `${stem}_${n}.json`);
        const task = author.Task(jobLabel(n, entry), "blender");
        task.addCommand(author.Command("blender-render", {
            exe: "{blender}",
            exeArgs: "{blenderArgs}",
            argsBefore: [],
            blendfile: settings.blendfile,
            args: ["-c", "footstep"].concat(jobArgv(entry, out, report, common)),
        }));
        job.addTask(task);
    }
}

// The job list of the "jobs" setting; throws (the Manager refuses the job, saying why)
// unless it is a non-empty list of valid jobs.
function readJobs(text) {
    let jobs;
    try {
        jobs = JSON.parse(text);
    } catch (e) {
        throw `the job list is not JSON (${e}): give the jobs_file (JOBS.json) or the jobs setting`;
    }
    if (!Array.isArray(jobs) || jobs.length === 0) {
        throw "the job list must be a non-empty JSON list of objects";
    }
    const problems = [];
    for (let i = 0; i < jobs.length; i++) {
        for (const why of jobProblems(jobs[i])) {
            problems.push(`job ${i + 1}: ${why}`);
        }
    }
    if (problems.length > 0) {
        throw `invalid job list: ${problems.join("; ")}`;
    }
    return jobs;
}

// What is wrong with one job (core/jobs.py check_job, but for the settings' names and
// ranges, which the bake itself checks).
function jobProblems(job) {
    if (job === null || typeof job !== "object" || Array.isArray(job)) {
        return [`not an object but ${JSON.stringify(job)}`];
    }
    const problems = [];
    for (const key of Object.keys(job)) {
        if (JOB_FIELDS.indexOf(key) < 0) problems.push(`unknown field '${key}' (fields: ${JOB_FIELDS.join(", ")})`);
    }
    if (typeof job.character !== "string" || job.character.trim() === "") {
        problems.push("'character' must be an armature's name");
    }
    for (const key of ["goal", "start", "report", "out"]) {
        if (given(job[key]) && (typeof job[key] !== "string" || job[key].trim() === "")) {
            problems.push(`'${key}' must be ${key === "report" || key === "out" ? "a file path" : "an object's name"}`);
        }
    }
    if (given(job.name) && typeof job.name !== "string") problems.push("'name' must be text");
    const f = job.frame_start;
    if (given(f) && !(typeof f === "number" && Number.isInteger(f) && Math.abs(f) <= MAX_FRAME)) {
        problems.push(`'frame_start' must be a whole number within ±${MAX_FRAME}`);
    }
    const h = job.goal_heading;
    if (given(h) && !(typeof h === "number" && Math.abs(h) < 1e6)) {
        problems.push("'goal_heading' must be a number (degrees)");
    }
    const b = job.body_on;
    if (given(b) && !(typeof b === "string" && ["object", "root"].indexOf(b.toLowerCase()) >= 0)) {
        problems.push("'body_on' must be \"object\" or \"root\"");
    }
    const v = job.via;
    if (given(v) && !(Array.isArray(v) && v.every((x) => typeof x === "string" && x.trim() !== "" && x.indexOf(",") < 0))) {
        problems.push("'via' must be a list of objects' names (waypoints, in order)");
    }
    const s = job.settings;
    if (given(s) && (typeof s !== "object" || Array.isArray(s))) problems.push("'settings' must be an object");
    return problems;
}

function given(value) {
    return value !== undefined && value !== null;
}

// The `footstep bake` arguments of one job: core/jobs.py job_argv, rule for rule.
function jobArgv(job, out, report, common) {
    const argv = ["bake", "--character", job.character];
    const named = [["goal", "--goal"], ["start", "--start"], ["name", "--name"]];
    for (let i = 0; i < named.length; i++) {
        if (job[named[i][0]]) argv.push(named[i][1], pyStr(job[named[i][0]]));
    }
    if (given(job.frame_start)) argv.push("--frame-start", String(Math.trunc(job.frame_start)));
    if (given(job.goal_heading)) argv.push("--goal-heading", pyFloat(Number(job.goal_heading)));
    if (given(job.via) && job.via.length) argv.push("--via", job.via.join(","));
    argv.push("--body-on", String(job.body_on || common.body_on || "object").toLowerCase());
    for (const key of ["traversable", "obstacles"]) {
        if (common[key]) argv.push(`--${key}`, common[key]);
    }
    if (common.markers) argv.push("--markers");
    if (common.keep_frame_range) argv.push("--keep-frame-range");
    const own = job.settings || {};
    const pairs = common.set.concat(Object.keys(own).map((k) => `${k}=${pyStr(own[k])}`));
    for (const pair of pairs) argv.push("--set", pair);
    if (out) argv.push("--out", out);
    if (report) argv.push("--report", report);
    return argv;
}

// Python's str() of a JSON value (True, None, 0.5, 1e-05), as job_argv formats a value.
function pyStr(value) {
    if (value === true) return "True";
    if (value === false) return "False";
    if (value === null || value === undefined) return "None";
    if (typeof value === "number") return Number.isInteger(value) ? String(value) : pyFloat(value);
    if (typeof value === "string") return value;
    return JSON.stringify(value);
}

// Python's repr() of a float: the shortest digits that read back the same, like
// JavaScript's, but "2.0" not "2", and exponents below 1e-4 and from 1e16 ("1e-05").
function pyFloat(x) {
    if (Number.isNaN(x)) return "nan";
    if (!Number.isFinite(x)) return x > 0 ? "inf" : "-inf";
    if (x === 0) return Object.is(x, -0) ? "-0.0" : "0.0";
    const ax = Math.abs(x);
    if (ax >= 1e-4 && ax < 1e16) {
        const s = String(x);
        return s.indexOf(".") < 0 ? s + ".0" : s;
    }
    const parts = x.toExponential().split("e");
    const exp = Number(parts[1]);
    return `${parts[0]}e${exp < 0 ? "-" : "+"}${Math.abs(exp) < 10 ? "0" : ""}${Math.abs(exp)}`;
}

// "a=1 b=2" -> ["a=1", "b=2"]
function splitPairs(text) {
    return String(text || "").split(/\s+/).filter((p) => p.length > 0);
}

// A job's own output path: absolute (or a Flamenco variable) as it is, else in the folder.
function inFolder(folder, p) {
    if (!p) return null;
    if (/^([\/\\]|[A-Za-z]:[\/\\]|\{)/.test(p)) return p;
    return path.join(folder, p);
}

// "job 3 'hero walk' (Hero to Door)", as core/jobs.py job_label names a job.
function jobLabel(n, job) {
    const name = job.name ? ` '${job.name}'` : "";
    return `job ${n}${name} (${job.character} to ${job.goal || "the 3D cursor"})`;
}
