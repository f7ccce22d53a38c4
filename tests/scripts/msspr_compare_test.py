#!/usr/bin/env python3
"""msspr_compare end to end on a tiny grid (2 agents x 2 seeds x 200 steps): a run killed
part way resumes where it stopped, finished runs are skipped, a run whose options differ
from the grid is refused, and report writes the table, the CSV and the learning curves.

usage: msspr_compare_test.py   (MSSPR_BIN: the directory holding msspr_train)
"""
import csv
import fcntl
import glob
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TOOL = os.path.join(ROOT, "scripts", "msspr_compare")
SAMPLE = os.path.join(ROOT, "rosbags", "pointmaze-medium-navigate-sample.bag")
STEPS, EVERY = 200, 50

TINY_MSPR = """scale: cpu
network: {encoder_hidden: 32, zsa_hidden: 32, goal_hidden: 32, critic_hidden: 32, actor_hidden: 32,
          zs_dim: 24, zsa_dim: 24, za_dim: 16, goal_dim: 8}
trainer: {batch_size: 16, log_every: 10}
"""
TINY_BASELINE = """scale: cpu
baseline: {hidden: 32, layers: 2, latent_dim: 32}
trainer: {batch_size: 16, log_every: 10}
"""


def grid_text(tmp):
    return f"""name: tiny
seeds: [0, 1]
threads: 1
checkpoint_every: 10
eval: {{every: {EVERY}, episodes: 1, seed: 0, max_steps: 40}}
tasks:
  - name: tiny-maze
    env: pointmaze-medium
    steps: {STEPS}
    data:
      - {{file: sample.bag, command: "cp {SAMPLE} {{file}}"}}
    agents:
      - {{name: mspr, configs: [{tmp}/tiny_mspr.yaml]}}
      - {{name: gcivl, agent: gcivl, configs: [{tmp}/tiny_baseline.yaml]}}
"""


def cpu_model_number():
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model") and line.split(":")[0].strip() == "model":
                return line.split(":", 1)[1].strip()
    return "?"


def read_json(path):
    with open(path) as f:
        return json.load(f)


def eval_steps(run_dir):
    steps = []
    with open(os.path.join(run_dir, "eval.csv")) as f:
        for rec in csv.reader(f):
            if len(rec) == 3 and rec[1] == "mean_success":
                steps.append(int(rec[0]))
    return steps


class MssprCompareTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="msspr_compare_test_")
        with open(os.path.join(self.tmp, "tiny_mspr.yaml"), "w") as f:
            f.write(TINY_MSPR)
        with open(os.path.join(self.tmp, "tiny_baseline.yaml"), "w") as f:
            f.write(TINY_BASELINE)
        self.grid = os.path.join(self.tmp, "grid.yaml")
        with open(self.grid, "w") as f:
            f.write(grid_text(self.tmp))
        self.out = os.path.join(self.tmp, "out")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def compare(self, *args, timeout=600):
        p = subprocess.run([sys.executable, TOOL] + list(args), capture_output=True, text=True, timeout=timeout)
        return p.returncode, p.stdout + p.stderr

    def run_dirs(self):
        return sorted(glob.glob(os.path.join(self.out, "runs", "tiny-maze", "*-s*")))

    def wait_unlocked(self, run_dir, timeout=60):
        """Waits until no msspr_train holds the run's lock (it exits on its parent's death)."""
        end = time.time() + timeout
        with open(os.path.join(run_dir, ".compare.lock"), "a") as f:
            while time.time() < end:
                try:
                    fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    fcntl.flock(f, fcntl.LOCK_UN)
                    return
                except OSError:
                    time.sleep(0.2)
        self.fail(f"{run_dir}: msspr_train still running {timeout} s after msspr_compare was killed")

    def test_grid_runs_resumes_after_kill_skips_finished_refuses_changed_and_reports(self):
        # 1. Start the grid, kill msspr_compare (SIGKILL) once a run has a checkpoint.
        p = subprocess.Popen([sys.executable, TOOL, "run", self.grid, "--out", self.out, "--jobs", "2"],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        deadline = time.time() + 300
        while time.time() < deadline and not glob.glob(os.path.join(self.out, "runs", "*", "*", "checkpoint.ckpt")):
            if p.poll() is not None:
                self.fail("msspr_compare ended before any checkpoint: " + p.stdout.read())
            time.sleep(0.1)
        p.send_signal(signal.SIGKILL)
        p.wait()
        p.stdout.close()
        for d in self.run_dirs():
            self.wait_unlocked(d)
        statuses = [read_json(os.path.join(d, "compare.json"))["status"] for d in self.run_dirs()]
        self.assertIn("running", statuses, "the killed runs are left marked running until the next run")
        interrupted = [d for d in self.run_dirs()]
        # status: a line per run; a run cut off part way says the step its training reached.
        rc, out = self.compare("status", self.out)
        self.assertEqual(rc, 0, out)
        for d in interrupted:
            name = "tiny-maze/" + os.path.basename(d)
            line = next((l for l in out.splitlines() if l.startswith(name + ": ")), None)
            self.assertIsNotNone(line, out)
            if read_json(os.path.join(d, "compare.json"))["status"] != "finished" and \
                    os.path.exists(os.path.join(d, "metrics.csv")):
                with open(os.path.join(d, "metrics.csv")) as f:
                    rows = list(csv.DictReader(f))
                if rows:  # killed before its first metrics row: nothing to say yet
                    self.assertIn(f"trained to step {int(rows[-1]['step']):,} of {STEPS:,}", line)
                else:
                    self.assertNotIn("trained to step", line)
        self.assertTrue(out.splitlines()[-1].endswith(" of 4 runs"), out)

        # 2. The same command finishes the grid; killed runs resume from their checkpoints.
        rc, out = self.compare("run", self.grid, "--out", self.out, "--jobs", "2")
        self.assertEqual(rc, 0, out)
        dirs = self.run_dirs()
        self.assertEqual([os.path.basename(d) for d in dirs], ["gcivl-s0", "gcivl-s1", "mspr-s0", "mspr-s1"])
        resumed = 0
        for d in dirs:
            rec = read_json(os.path.join(d, "compare.json"))
            self.assertEqual(rec["status"], "finished", d)
            # Every evaluation of the schedule exactly once, at the same steps for every run.
            self.assertEqual(eval_steps(d), list(range(EVERY, STEPS + 1, EVERY)), d)
            if d in interrupted and len(rec["segments"]) == 2:
                seg0, seg1 = rec["segments"]
                self.assertEqual(seg0["exit"], "lost (msspr_compare was killed)")
                self.assertEqual(seg1["step_end"], STEPS)
                if "--resume" not in seg1["command"]:
                    # Killed before msspr_train wrote its run.yaml: the run starts anew, at 0.
                    self.assertEqual(seg1["step_start"], 0, d)
                    self.assertIn("--data", seg1["command"])
                # From its last checkpoint (a run killed before its first starts at 0).
                elif seg1["step_start"] > 0:
                    resumed += 1
                    # The lost segment's time reaches at least its training's time at the step
                    # the next one resumed from (metrics.csv keeps the rows up to it).
                    with open(os.path.join(d, "metrics.csv")) as f:
                        walls = {int(r["step"]): float(r["wall_s"]) for r in csv.DictReader(f)}
                    if seg1["step_start"] in walls:
                        self.assertGreaterEqual(seg0["wall_s"] + 1e-6, walls[seg1["step_start"]], d)
            # Every command ran at one thread with the grid's evaluation.
            for seg in rec["segments"]:
                cmd = seg["command"]
                self.assertEqual(cmd[cmd.index("--threads") + 1], "1")
                self.assertEqual(cmd[cmd.index("--eval-every") + 1], str(EVERY))
        self.assertGreaterEqual(resumed, 1, "the run with a checkpoint at the kill resumed from it")

        # 3. Run again: everything finished is skipped, nothing new starts.
        rc, out = self.compare("run", self.grid, "--out", self.out, "--jobs", "2")
        self.assertEqual(rc, 0, out)
        self.assertIn("4 finished, 0 to run, 0 refused", out)
        self.assertNotIn("msspr_compare: started", out)
        rc, out = self.compare("status", self.out)
        self.assertEqual(rc, 0, out)
        self.assertEqual(out.splitlines()[-1], "4 finished of 4 runs", out)
        self.assertIn(f"tiny-maze/mspr-s0: finished, evaluated to step {STEPS:,} of {STEPS:,}", out)

        # 3b. --records keeps each finished run's record (no checkpoint, no data); a fresh
        # directory given the records runs nothing, and the records report as the runs do.
        rec_dir = os.path.join(self.tmp, "records")
        rc, out = self.compare("run", self.grid, "--out", self.out, "--records", rec_dir)
        self.assertEqual(rc, 0, out)
        kept = sorted(glob.glob(os.path.join(rec_dir, "runs", "tiny-maze", "*-s*")))
        self.assertEqual([os.path.basename(d) for d in kept], ["gcivl-s0", "gcivl-s1", "mspr-s0", "mspr-s1"])
        for d in kept:
            names = set(os.listdir(d))
            self.assertTrue({"compare.json", "eval.csv", "segment_00.log"} <= names, names)
            self.assertFalse([n for n in names if n.endswith((".ckpt", ".pt", ".bag", ".tmp"))], names)
            self.assertEqual(read_json(os.path.join(d, "compare.json")),
                             read_json(os.path.join(self.out, "runs", "tiny-maze", os.path.basename(d),
                                                    "compare.json")))
        fresh = os.path.join(self.tmp, "fresh")
        rc, out = self.compare("run", self.grid, "--out", fresh, "--records", rec_dir, "--jobs", "2")
        self.assertEqual(rc, 0, out)
        self.assertIn("4 finished run(s) taken from the records", out)
        self.assertIn("4 finished, 0 to run, 0 refused", out)
        self.assertFalse(glob.glob(os.path.join(fresh, "runs", "*", "*", "checkpoint.ckpt")))
        rc, out = self.compare("status", fresh, "--grid", self.grid, "--records", rec_dir)
        self.assertEqual(rc, 0, out)
        self.assertEqual(out.splitlines()[-1], "4 finished of 4 runs", out)
        for where in (self.out, rec_dir):
            rc, out = self.compare("report", where, "--md", os.path.join(self.tmp, "r.md"),
                                   "--csv", os.path.join(self.tmp, os.path.basename(where) + ".csv"),
                                   "--png-dir", self.tmp)
            self.assertEqual(rc, 0, out)
        with open(os.path.join(self.tmp, "out.csv")) as f1, open(os.path.join(self.tmp, "records.csv")) as f2:
            self.assertEqual(f1.read(), f2.read())

        # 4. A comment in a config changes nothing; a grid whose options differ is refused for
        # the runs it touches, named.
        with open(os.path.join(self.tmp, "tiny_mspr.yaml"), "a") as f:
            f.write("# a comment\n")
        rc, out = self.compare("run", self.grid, "--out", self.out)
        self.assertEqual(rc, 0, out)
        with open(os.path.join(self.tmp, "tiny_mspr.yaml"), "a") as f:
            f.write("agent: {bc_weight: 0.5}\n")
        rc, out = self.compare("run", self.grid, "--out", self.out)
        self.assertEqual(rc, 1, out)
        self.assertIn("refused tiny-maze/mspr-s0: options differ from the grid (the options its configs resolve to", out)
        self.assertIn("refused tiny-maze/mspr-s1", out)
        self.assertNotIn("refused tiny-maze/gcivl", out)
        with open(os.path.join(self.tmp, "tiny_mspr.yaml"), "w") as f:
            f.write(TINY_MSPR)

        # 5. The report: a row per agent with mean ± sd over 2 seeds at the full budget.
        rc, out = self.compare("report", self.out)
        self.assertEqual(rc, 0, out)
        with open(os.path.join(self.out, "report.md")) as f:
            md = f.read()
        rows = [l for l in md.splitlines() if l.startswith("| tiny-maze |")]
        self.assertEqual(len(rows), 2, md)
        for row, agent in zip(rows, ["mspr", "gcivl"]):
            cells = [c.strip() for c in row.strip("|").split("|")]
            self.assertEqual(cells[1], agent)
            self.assertRegex(cells[2], r"^\d+\.\d ± \d+\.\d$")
            self.assertEqual(cells[3], "2")
            self.assertEqual(cells[4], f"{STEPS}")
            self.assertGreater(float(cells[5]), 0.0)  # steps/s
            self.assertEqual(cells[8], f"{cells[2]} at {STEPS}")  # both agents at equal steps
            # What the runs trained in, read from their logs: the precision and this CPU's model.
            self.assertRegex(cells[10], rf"^(fp32|bf16), model {cpu_model_number()}$")
        with open(os.path.join(self.out, "report.csv")) as f:
            recs = list(csv.DictReader(f))
        self.assertEqual(len(recs), 4)
        for r in recs:
            # Each seed's figure is the mean of its last 3 evaluations, read from eval.csv.
            evals = [float(x.split(":")[1]) for x in r["evaluations"].split()]
            self.assertEqual(len(evals), STEPS // EVERY)
            self.assertAlmostEqual(float(r["last3_mean_success"]), sum(evals[-3:]) / 3, places=4)
            self.assertIn(r["precision"], ("fp32", "bf16"))
            self.assertIn(f"model {cpu_model_number()}", r["cpu"])
        # The statistic in the table is the mean and sample sd of the two seeds' figures.
        for agent, row in zip(["mspr", "gcivl"], rows):
            figs = [float(r["last3_mean_success"]) * 100 for r in recs if r["agent"] == agent]
            m = sum(figs) / 2
            sd = abs(figs[0] - figs[1]) / 2 ** 0.5
            self.assertIn(f"{m:.1f} ± {sd:.1f}", row)
        # --per-task: each evaluation task's last-3 success (mean over seeds) and the mean |change|
        # of a task's success between consecutive evaluations from the third on, from eval.csv.
        # Tiny runs succeed nowhere, so a copy of the runs gets seeded per-task successes.
        varied = os.path.join(self.tmp, "varied")
        shutil.copytree(self.out, varied)
        rng = random.Random(7)
        for d in glob.glob(os.path.join(varied, "runs", "tiny-maze", "*-s*")):
            path = os.path.join(d, "eval.csv")
            with open(path) as f:
                recs = list(csv.reader(f))
            for rec in recs:
                if len(rec) == 3 and rec[1].startswith("success_task"):
                    rec[2] = f"{rng.randrange(0, 51) / 50:.6f}"
            with open(path, "w", newline="") as f:
                csv.writer(f).writerows(recs)
        per_task = os.path.join(self.tmp, "tasks.md")
        rc, out = self.compare("report", varied, "--per-task", per_task)
        self.assertEqual(rc, 0, out)
        with open(per_task) as f:
            task_rows = [l for l in f.read().splitlines() if l.startswith("| tiny-maze |")]
        self.assertEqual(len(task_rows), 2, task_rows)
        for row, agent in zip(task_rows, ["mspr", "gcivl"]):
            cells = [c.strip() for c in row.strip("|").split("|")]
            self.assertEqual(cells[1], agent)
            per_seed = []
            for seed in (0, 1):
                ev = {}
                with open(os.path.join(varied, "runs", "tiny-maze", f"{agent}-s{seed}", "eval.csv")) as f:
                    for rec in csv.reader(f):
                        if len(rec) == 3 and rec[1].startswith("success_task"):
                            ev.setdefault(int(rec[1][len("success_task"):]), []).append((int(rec[0]), float(rec[2])))
                per_seed.append({k: [v for s, v in sorted(c) if s % EVERY == 0] for k, c in ev.items()})
            self.assertEqual(sorted(per_seed[0]), [1, 2, 3, 4, 5])
            for k in range(1, 6):
                want = sum(sum(p[k][-3:]) / 3 for p in per_seed) / 2
                self.assertAlmostEqual(float(cells[1 + k]), 100 * want, delta=0.051, msg=row)
            changes = [abs(c[i + 1] - c[i]) for p in per_seed for c in p.values() for i in range(2, len(c) - 1)]
            self.assertAlmostEqual(float(cells[7]), 100 * sum(changes) / len(changes), delta=0.051, msg=row)
        # A run resumed after a lost segment, its new segment still running (its lock held):
        # the time so far is the lost segment's plus the running one's, not the running
        # segment's evaluations counted again into the lost one; its step is its metrics'.
        live = os.path.join(self.tmp, "live")
        shutil.copytree(self.out, live)
        run = os.path.join(live, "runs", "tiny-maze", "mspr-s0")
        rec = read_json(os.path.join(run, "compare.json"))
        now = time.time()
        seg0 = dict(rec["segments"][0], start=now - 1000.0, end=now - 990.0, wall_s=10.0, step_start=0,
                    step_end=None, exit="lost (msspr_compare was killed)", log="segment_00.log")
        seg1 = {"start": now - 60.0, "end": None, "log": "segment_01.log", "load_sum": 0.0, "load_n": 0,
                "load_max": 0.0, "command": seg0["command"]}
        rec["segments"], rec["status"] = [seg0, seg1], "running"
        with open(os.path.join(run, "compare.json"), "w") as f:
            json.dump(rec, f)
        with open(os.path.join(run, "segment_01.log"), "w") as f:
            f.write(f"msspr_train: resumed from {run}/checkpoint.ckpt at step {EVERY}\n")
        with open(os.path.join(run, "eval.csv")) as f:  # the evaluations after it: far into a process
            recs = [r if len(r) != 3 or r[1] != "wall_s" or int(r[0]) <= EVERY else [r[0], r[1], "5000"]
                    for r in csv.reader(f)]
        with open(os.path.join(run, "eval.csv"), "w", newline="") as f:
            csv.writer(f).writerows(recs)
        with open(os.path.join(run, ".compare.lock"), "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            rc, out = self.compare("status", live)
            fcntl.flock(lock, fcntl.LOCK_UN)
        self.assertEqual(rc, 0, out)
        line = next(l for l in out.splitlines() if l.startswith("tiny-maze/mspr-s0: "))
        self.assertIn(f"running, trained to step {STEPS:,} of {STEPS:,}", line)
        minutes = float(re.search(r", ([\d.]+) min so far", line).group(1))
        self.assertAlmostEqual(minutes, 70.0 / 60.0, delta=0.15, msg=line)
        # --grid reports a grid file's runs from the directory (grids may share one --out); the
        # mspr runs, of another config than this grid's, are left out of it, named.
        with open(os.path.join(self.tmp, "tiny_mspr2.yaml"), "w") as f:
            f.write(TINY_MSPR + "agent: {bc_weight: 0.5}\n")
        grid2 = os.path.join(self.tmp, "grid2.yaml")
        with open(grid2, "w") as f:
            f.write(grid_text(self.tmp).replace("tiny_mspr.yaml", "tiny_mspr2.yaml"))
        other = os.path.join(self.tmp, "other.md")
        rc, out = self.compare("report", self.out, "--grid", grid2, "--md", other)
        self.assertEqual(rc, 0, out)
        with open(other) as f:
            text = f.read()
        other_rows = [l for l in text.splitlines() if l.startswith("| tiny-maze |")]
        self.assertEqual(other_rows[1], rows[1])
        self.assertIn("| tiny-maze | mspr | not run | 0 |", other_rows[0])
        self.assertIn("Left out: 2 run(s) whose options differ", text)
        # Published figures in the grid add a column beside the runs' own and its source; they
        # are not part of a run's identity, so the same runs are reported, none left out.
        grid3 = os.path.join(self.tmp, "grid3.yaml")
        with open(grid3, "w") as f:
            f.write("published_source: the paper's Table 3\n" + grid_text(self.tmp)
                    .replace("{name: mspr,", "{name: mspr, published: '64 ± 9',")
                    .replace("{name: gcivl,", "{name: gcivl, published: 63,"))
        pub = os.path.join(self.tmp, "published.md")
        rc, out = self.compare("report", self.out, "--grid", grid3, "--md", pub)
        self.assertEqual(rc, 0, out)
        with open(pub) as f:
            text = f.read()
        self.assertIn("| success (%) | published (%) | seeds |", text)
        self.assertIn("published success on the task: the paper's Table 3.", text)
        self.assertNotIn("Left out", text)
        for row, published in zip(rows, ["64 ± 9", "63"]):
            cells = [c.strip() for c in row.strip("|").split("|")]
            self.assertIn("| " + " | ".join(cells[:3] + [published] + cells[3:]) + " |", text)
        with open(grid3, "w") as f:
            f.write("published_source: x\n" + grid_text(self.tmp).replace("{name: mspr,", "{name: mspr, published: 120,"))
        rc, out = self.compare("report", self.out, "--grid", grid3, "--md", pub)
        self.assertEqual(rc, 2, out)
        self.assertIn("agent mspr: published must be a success rate in % (0 to 100)", out)
        # --insert puts the same table into a document between its markers, again and again.
        doc = os.path.join(self.tmp, "results.md")
        with open(doc, "w") as f:
            f.write("# Results\n\n<!-- msspr_compare report: tiny -->\n\n## Next\n")
        for _ in range(2):
            rc, out = self.compare("report", self.out, "--insert", doc)
            self.assertEqual(rc, 0, out)
        with open(doc) as f:
            text = f.read()
        for row in rows:
            self.assertEqual(text.count(row), 1, text)
        self.assertEqual(text.count("<!-- end msspr_compare report -->"), 1, text)
        self.assertIn("](out/curves_tiny-maze.png)", text)
        self.assertTrue(text.startswith("# Results\n") and text.endswith("## Next\n"), text)
        png = os.path.join(self.out, "curves_tiny-maze.png")
        with open(png, "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")

    def test_shipped_grids_resolve_and_their_records_are_finished_on_this_cpu(self):
        # Every grid in config/grids: its configs are found and resolve to valid options. A grid
        # with records in docs/grids (made on one machine) finds them finished here, whatever
        # this CPU resolves precision auto to: not refused as changed.
        grids = sorted(glob.glob(os.path.join(ROOT, "config", "grids", "*.yaml")))
        self.assertGreaterEqual(len(grids), 2)
        with_records = 0
        for g in grids:
            name = os.path.splitext(os.path.basename(g))[0]
            records = os.path.join(ROOT, "docs", "grids", name)
            has_records = os.path.isdir(records)
            args = ["run", g, "--out", self.out, "--dry-run"] + (["--records", records] if has_records else [])
            with_records += has_records
            rc, out = self.compare(*args)
            self.assertEqual(rc, 0, g + ": " + out)
            counts = re.search(r"(\d+) runs: (\d+) finished, (\d+) to run", out)
            self.assertIsNotNone(counts, g + ": " + out)
            if int(counts.group(3)) > 0:  # the command of each run to do, on the grid's schedule
                self.assertIn("--eval-every 5000 --eval-episodes 50 --eval-seed 0", out, g)
            self.assertFalse(os.path.exists(self.out), "--dry-run wrote nothing")
            self.assertNotIn("refused", out.replace(" 0 refused", ""), g + ": " + out)
            if has_records:
                self.assertGreater(int(counts.group(2)), 0, g + ": no record found finished")
        self.assertGreaterEqual(with_records, 2)

    def test_auto_precision_is_fingerprinted_alike_on_every_cpu(self):
        # trainer.precision auto resolves by CPU kind (bf16 or fp32); the fingerprint of a run's
        # options takes it as on a CPU with fast bfloat16, so it equals an explicit bf16's on
        # every machine, and an explicit fp32 stays apart.
        import importlib.util
        from importlib.machinery import SourceFileLoader
        loader = SourceFileLoader("msspr_compare_module", TOOL)
        compare = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name, loader))
        loader.exec_module(compare)
        sha = {}
        for precision in ("auto", "bf16", "fp32"):
            layer = os.path.join(self.tmp, f"precision_{precision}.yaml")
            with open(layer, "w") as f:
                f.write(f"trainer: {{precision: {precision}}}\n")
            sha[precision] = compare.resolved_options_sha256(None, [os.path.join(self.tmp, "tiny_mspr.yaml"), layer])
        self.assertEqual(sha["auto"], sha["bf16"])
        self.assertNotEqual(sha["auto"], sha["fp32"])

    def test_bad_grid_is_an_error_naming_the_problem(self):
        with open(self.grid, "a") as f:
            f.write("bogus: 1\n")
        rc, out = self.compare("run", self.grid, "--out", self.out)
        self.assertEqual(rc, 2, out)
        self.assertIn("unknown key 'bogus'", out)
        with open(self.grid, "w") as f:
            f.write(grid_text(self.tmp).replace("steps: 200", "steps: 10"))
        rc, out = self.compare("run", self.grid, "--out", self.out)
        self.assertEqual(rc, 2, out)
        self.assertIn("steps 10 is below eval.every 50", out)


if __name__ == "__main__":
    unittest.main(verbosity=2)
