// Compile a Flamenco job with a job type script, outside Flamenco, and print what it made.
//
//     node flamenco/check_job_type.js flamenco/footstep_bake.js SETTINGS.json
//
// SETTINGS.json holds the job's settings (as the Flamenco add-on would submit them). The
// script runs with stand-ins for what the Manager's JavaScript engine gives a job type
// (author.Task, author.Command, job.addTask, task.addCommand, path, print), which record
// every task and command. Prints {"label", "settings", "tasks": [{"name", "type",
// "commands": [{"type", "parameters"}], "dependencies"}]} as JSON; when compileJob throws,
// prints {"error": "..."} and exits with status 1.

"use strict";

const fs = require("fs");
const nodePath = require("path");
const vm = require("vm");

function stubs(log) {
    const author = {
        Task(name, type) {
            const task = { name, type, commands: [], dependencies: [] };
            return {
                _record: task,
                addCommand(command) { task.commands.push(command); },
                addDependency(other) { task.dependencies.push(other._record.name); },
            };
        },
        Command(type, parameters) {
            return { type, parameters: JSON.parse(JSON.stringify(parameters)) };
        },
    };
    const path = {
        join: (...parts) => nodePath.posix.join(...parts),
        basename: (p) => nodePath.posix.basename(p),
        dirname: (p) => nodePath.posix.dirname(p),
        stem: (p) => nodePath.posix.basename(p, nodePath.posix.extname(p)),
    };
    return { author, path, print: (...args) => log.push(args.join(" ")) };
}

function main(argv) {
    if (argv.length !== 2) {
        process.stderr.write("usage: node check_job_type.js JOB_TYPE.js SETTINGS.json\n");
        return 2;
    }
    const log = [];
    const context = vm.createContext(stubs(log));
    const source = fs.readFileSync(argv[0], "utf-8");
    const exported = vm.runInContext(`${source}\n;({ JOB_TYPE, compileJob })`, context, { filename: argv[0] });
    const tasks = [];
    const job = {
        name: "check", priority: 50, created: new Date(0),
        settings: JSON.parse(fs.readFileSync(argv[1], "utf-8")),
        addTask(task) { tasks.push(task._record); },
    };
    try {
        exported.compileJob(job);
    } catch (e) {
        process.stdout.write(JSON.stringify({ error: String(e), log }) + "\n");
        return 1;
    }
    const out = { label: exported.JOB_TYPE.label, settings: exported.JOB_TYPE.settings, tasks, log };
    process.stdout.write(JSON.stringify(out) + "\n");
    return 0;
}

process.exitCode = main(process.argv.slice(2));
