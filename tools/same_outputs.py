#!/usr/bin/env python3
"""Every study's outputs from two builds of squeal, compared byte for byte.

A refactor must leave every study's outputs byte-identical. This script runs each study with
two binaries, BIN_A (before the change) and BIN_B (after it), each into its own output folder
and its own empty cache (so that every stage instance is computed by that binary, none read
from the other's cache), then compares the two output trees file by file. Python 3 standard
library only.

    tools/same_outputs.py --before BIN_A --after BIN_B [--work DIR]
                          [--studies pipelines/a.yaml ...] [--skip STUDY ...]
                          [--phase before|after|both] [--reference DIR] [--rev REV]
                          [--after-rev REV] [--renamed OLD=NEW ...] [--timeout MINUTES]

    # the reference, once, early, with a build from before the change kept aside:
    SQUEAL_LOG=warn tools/same_outputs.py --before ../squeal-before --after ../squeal-before \\
        --work ../compare --phase before --rev REV_BEFORE
    # later, with the new build: runs it, then compares with the reference
    SQUEAL_LOG=warn tools/same_outputs.py --before ../squeal-before \\
        --after target/release/squeal --work ../compare --phase after \\
        --after-rev HEAD --renamed pipelines/transient.yaml=pipelines/quick.yaml

The study files: both sides must run the same ones, while the working tree's may change during
a refactor. The phase that makes the reference (`before`, `both`) copies `pipelines/` at git
revision REV (default HEAD) into WORK/studies/ (with WORK/studies/snapshot.json: commit and
tree), and every later phase runs those copies; a reference made from another `pipelines/`
tree is refused. When the change renames what studies write (an input, a study file), the
after side runs the study files of `--after-rev` instead (copied into WORK/studies-after/),
`--renamed OLD=NEW` naming the study that replaced a removed one. A study whose file differs
between the two revisions may write outputs the reference does not have (new stages): they
are listed, allowed; every output of the reference must still be there, byte for byte. The
runs are made from WORK/studies, the study path as given
(`pipelines/hoffmann/hoffmann.yaml`), so that files a study reads relative to its folder
(`hoffmann/*.mtx`) resolve, and squeal's own run record (`pipelines/.squeal/record/`, which only
explains the plan) goes there rather than into the working tree.

Each run is `BIN run STUDY --out WORK/<side>/<stem>/out --cache WORK/<side>/<stem>/cache -j 2`
(`--cache` placed where `BIN run --help` / `BIN --help` say the binary takes it; SQUEAL_CACHE
is unset for it), <side> being `before` or `after` and <stem> the study's file name without
`.yaml` (two selected studies with one stem are refused). A run's folder WORK/<side>/<stem> is
emptied first; beside `out` and `cache` it holds `stdout.txt`, `stderr.txt` and `run.json`
(command, exit code, seconds, timed out). Set SQUEAL_LOG (e.g. `warn`) in the environment.

Options:
  --studies    the study files (default: every pipelines/**/*.yaml, sorted)
  --skip       studies left out, by path or stem (e.g. `--skip time_step_study`)
  --phase      `before`: run BIN_A only (the reference, made once); `after`: run BIN_B only,
               then compare with the reference; `both` (default): both runs, then compare
  --reference  (`after` only) the work folder holding the reference, its before/ and studies/
               (default: WORK): to compare a run made into one work folder with the reference
               made in another
  --rev        the git revision whose pipelines/ are run (default: HEAD), read when the
               reference is made
  --after-rev  (`after`, `both`) the git revision whose pipelines/ the after side runs
               (default: the reference's study files)
  --renamed    OLD=NEW study paths: the after side runs NEW for the reference's OLD
  --timeout    stop a run (its process group) that takes longer than this many minutes
               (default: no limit); it is recorded as timed out and its study is not the same

What is compared: every file of the two output folders, by relative path; identical bytes are
required, except for
  - `manifest.parquet` at the top of the output folder: the run's manifest, each instance's
    wall and compute times and its ran/cached status, not results (a stage table of that name
    deeper down is compared);
  - hidden files and folders (a path component starting with `.`): the engine's bookkeeping,
    `.squeal-exports.json` (the cache digests each export was written from: they change with a
    stage's version, or with an upstream `compute_s`, while the outputs do not) and
    `.squeal-tmp-*` (temporaries of an interrupted write);
  - timing-dependent outputs, which must exist on both sides but whose bytes may differ
    (reported apart, "timing-dependent differing, allowed"): the folders of every stage fed,
    directly or further down, by a `compute_s` output, found from `BIN dag STUDY` (an edge
    labelled `compute_s → ...`). `compute_s` is the wall-clock time an instance took; it
    differs from one run to the next with one binary. Today that is `pareto/` of basis_study and
    time_step_study (`points.parquet`: run_s, build_s, speed-ups and the fronts they decide;
    `fronts.png`/`.svg`: the points drawn at their run times); a small pareto study run twice
    with one binary gave different bytes for exactly these three files and identical ones for
    everything else. The errors those tables carry are the `compare` stages' own outputs,
    compared byte for byte.
  Nothing else is excluded: the same binary run twice (a fresh cache each time, -j 2) writes
  byte-identical outputs for every study: no file carries a timestamp, host or path, and the
  threaded solvers give the same bits run to run.

A study is "same" when both runs finished (no timeout) with the same exit code and every
compared file is identical and present on both sides. A study that fails on both sides with
the same exit code (pipelines/stress.yaml may hold stages meant to fail) is "same" only if the
outputs it did write are identical too.

Output: one line per study (files compared, identical, differing with up to 10 paths, files on
one side only, exit codes before/after, run times before/after) and a total; WORK/summary.json
holds the same as JSON. Exit status: `after`/`both`: 0 only if every study is the same;
`before`: 0 if every run finished (whatever its exit code, recorded for the comparison), 1 if
one timed out or could not start; 2: usage error.

Slow studies: basis_study and time_step_study (the full 31,500-DOF brake over 10 ms at 1 us,
then a dozen and more reduced runs) take tens of minutes each; leave them out of a quick check
with `--skip basis_study time_step_study`, or give them an idle machine.
"""

import argparse
import filecmp
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SIDES = ("before", "after")
MAX_LISTED = 10
# The top-level file of an output folder that is not an output: the run's manifest (times,
# statuses). Only at the top: a stage's table of that name deeper down is compared.
MANIFEST = "manifest.parquet"


def fail_usage(message):
    print(f"same_outputs.py: {message}", file=sys.stderr)
    sys.exit(2)


def git(*args):
    return subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, text=True)


def snapshot(studies_dir, rev, making):
    """The study files both sides run: `pipelines/` at git revision `rev`, copied once.

    The working tree's study files may change while a refactor goes on; the two sides must run
    the same ones, so they are taken from a revision into WORK/studies/ by the phase that makes
    the reference and reused as they are by `--phase after`. Returns the snapshot's record."""
    stamp = studies_dir / "snapshot.json"
    recorded = json.loads(stamp.read_text()) if stamp.is_file() else None
    if not making:
        if recorded is None:
            fail_usage(f"no study snapshot {stamp}: run --phase before (or both) first")
        return recorded
    commit = git("rev-parse", "--verify", f"{rev}^{{commit}}")
    tree = git("rev-parse", "--verify", f"{rev}:pipelines")
    if commit.returncode or tree.returncode:
        fail_usage(f"--rev {rev}: no such revision with a pipelines/ folder in {REPO}")
    wanted = {"rev": rev, "commit": commit.stdout.strip(), "tree": tree.stdout.strip()}
    if recorded is not None:
        if recorded["tree"] != wanted["tree"]:
            fail_usage(
                f"{studies_dir} holds pipelines/ of {recorded['commit']} (tree {recorded['tree']}), "
                f"--rev {rev} has tree {wanted['tree']}: the references were made with the other "
                f"study files; pass --rev {recorded['commit']}, or remove {studies_dir} and remake "
                "every reference"
            )
        return recorded
    studies_dir.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", wanted["commit"], "pipelines"],
        capture_output=True,
    )
    if archive.returncode:
        fail_usage(f"git archive {wanted['commit']} pipelines: {archive.stderr.decode().strip()}")
    subprocess.run(["tar", "-x", "-C", str(studies_dir)], input=archive.stdout, check=True)
    stamp.write_text(json.dumps(wanted, indent=2) + "\n")
    return wanted


def snapshot_after(studies_dir, rev):
    """`pipelines/` at git revision `rev` for the after side, copied afresh."""
    commit = git("rev-parse", "--verify", f"{rev}^{{commit}}")
    if commit.returncode:
        fail_usage(f"--after-rev {rev}: no such revision in {REPO}")
    if studies_dir.exists():
        subprocess.run(["rm", "-rf", "--", str(studies_dir)], check=True)
    studies_dir.mkdir(parents=True)
    archive = subprocess.run(
        ["git", "-C", str(REPO), "archive", "--format=tar", commit.stdout.strip(), "pipelines"],
        capture_output=True,
    )
    if archive.returncode:
        fail_usage(f"git archive {rev} pipelines: {archive.stderr.decode().strip()}")
    subprocess.run(["tar", "-x", "-C", str(studies_dir)], input=archive.stdout, check=True)
    return {"rev": rev, "commit": commit.stdout.strip()}


def default_studies(root):
    return sorted(str(path.relative_to(root)) for path in (root / "pipelines").rglob("*.yaml"))


def study_path(arg, root):
    """A study as a path relative to the snapshot's root (the repository's layout)."""
    path = Path(arg)
    if path.is_absolute():
        for base in (REPO, Path.cwd()):
            try:
                path = path.relative_to(base)
                break
            except ValueError:
                continue
        else:
            fail_usage(f"{arg}: a study of the repository, pipelines/...")
    elif not (root / path).is_file() and (Path.cwd() / path).resolve().is_relative_to(REPO):
        path = (Path.cwd() / path).resolve().relative_to(REPO)
    if not (root / path).is_file():
        fail_usage(f"no study {path} in the study snapshot {root}")
    return path.as_posix()


def cache_placement(binary):
    """Whether `--cache` goes after `run` (as a `run` option) or before it (global)."""
    def help_of(*args):
        try:
            return subprocess.run(
                [binary, *args, "--help"], capture_output=True, text=True, timeout=60
            ).stdout
        except OSError as err:
            fail_usage(f"cannot run {binary}: {err}")

    if "--cache" in help_of("run"):
        return "after"
    if "--cache" in help_of():
        return "before"
    fail_usage(f"{binary} takes no --cache option (neither `run --help` nor `--help` shows it)")


def run_command(binary, study, out, cache, placement):
    if placement == "before":
        return [binary, "--cache", str(cache), "run", study, "--out", str(out), "-j", "2"]
    return [binary, "run", study, "--out", str(out), "--cache", str(cache), "-j", "2"]


def timing_stages(binary, study, root):
    """Stages downstream of a `compute_s` output (wall-clock times), from `BIN dag STUDY`."""
    try:
        dot = subprocess.run(
            [binary, "dag", study], capture_output=True, text=True, cwd=root, timeout=300
        )
    except (OSError, subprocess.TimeoutExpired):
        return None
    if dot.returncode != 0:
        return None
    names, edges = {}, []
    for line in dot.stdout.splitlines():
        node = re.match(r'\s*(n\d+)\s*\[label="([^"]*)"', line)
        edge = re.match(r'\s*(n\d+)\s*->\s*(n\d+)\s*\[label="([^"]*)"', line)
        if edge:
            edges.append((edge.group(1), edge.group(2), edge.group(3)))
        elif node:
            # "stage[coords]\nkind": the stage name, which is its output folder.
            names[node.group(1)] = re.split(r"\[|\\n", node.group(2))[0]
    timed = {dst for src, dst, label in edges if label.split("→")[0].strip() == "compute_s"}
    while True:
        more = {dst for src, dst, _ in edges if src in timed} - timed
        if not more:
            break
        timed |= more
    return sorted({names[node] for node in timed if node in names})


def run_side(side, binary, study, stem, side_dir, root, timeout_s):
    """Runs one binary on one study into side_dir (emptied first); returns its record."""
    folder = side_dir / stem
    if folder.exists():
        subprocess.run(["rm", "-rf", "--", str(folder)], check=True)
    folder.mkdir(parents=True)
    placement = cache_placement(binary)
    command = run_command(binary, study, folder / "out", folder / "cache", placement)
    record = {
        "side": side,
        "study": study,
        "binary": binary,
        "command": command,
        "cwd": str(root),
        "squeal_log": os.environ.get("SQUEAL_LOG"),
        "timing_stages": timing_stages(binary, study, root),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    print(f"{stem}: running {side}: {' '.join(command)}", flush=True)
    env = dict(os.environ)
    env.pop("SQUEAL_CACHE", None)  # --cache is given; no stray default
    started = time.monotonic()
    timed_out = False
    try:
        with open(folder / "stdout.txt", "wb") as stdout, open(folder / "stderr.txt", "wb") as stderr:
            process = subprocess.Popen(
                command, cwd=root, env=env, stdout=stdout, stderr=stderr, start_new_session=True
            )
            try:
                exit_code = process.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                timed_out = True
                stop(process)
                exit_code = process.returncode
            except KeyboardInterrupt:
                stop(process)
                raise
    except OSError as err:
        record.update(exit_code=None, error=str(err), seconds=0.0, timed_out=False)
        (folder / "run.json").write_text(json.dumps(record, indent=2) + "\n")
        return record
    record.update(
        exit_code=exit_code,
        timed_out=timed_out,
        seconds=round(time.monotonic() - started, 1),
        finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    )
    (folder / "run.json").write_text(json.dumps(record, indent=2) + "\n")
    return record


def stop(process):
    """Stops a run and whatever it started (its own process group), gently then not."""
    for sig, grace in ((signal.SIGTERM, 30), (signal.SIGKILL, 30)):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(timeout=grace)
            return
        except subprocess.TimeoutExpired:
            continue


def outputs(out):
    """Relative paths of the files compared under an output folder."""
    files = set()
    if not out.is_dir():
        return files
    for root, dirs, names in os.walk(out):
        dirs[:] = [name for name in dirs if not name.startswith(".")]
        for name in names:
            relative = (Path(root) / name).relative_to(out)
            if name.startswith(".") or str(relative) == MANIFEST:
                continue
            files.add(relative.as_posix())
    return files


def compare(before_out, after_out, timed):
    """File-by-file comparison of two output folders."""
    before, after = outputs(before_out), outputs(after_out)
    common = sorted(before & after)

    def is_timed(path):
        return path.split("/", 1)[0] in timed

    differing, timing_differing, identical = [], [], 0
    for path in common:
        if filecmp.cmp(before_out / path, after_out / path, shallow=False):
            identical += 1
        elif is_timed(path):
            timing_differing.append(path)
        else:
            differing.append(path)
    return {
        "compared": len(common),
        "identical": identical,
        "differing": differing,
        "timing_dependent_differing": timing_differing,
        "only_before": sorted(before - after),
        "only_after": sorted(after - before),
    }


def listed(paths):
    shown = ", ".join(paths[:MAX_LISTED])
    return shown + (f", ... (+{len(paths) - MAX_LISTED} more)" if len(paths) > MAX_LISTED else "")


def exit_text(record):
    if record is None:
        return "no run"
    if record.get("timed_out"):
        return "timeout"
    if record.get("exit_code") is None:
        return "not started"
    return str(record["exit_code"])


def seconds_text(record):
    return "-" if record is None else f"{record.get('seconds', 0.0):.1f} s"


def load_record(folder):
    try:
        return json.loads((folder / "run.json").read_text())
    except (OSError, ValueError):
        return None


def main():
    parser = argparse.ArgumentParser(
        description="Run every study with two squeal binaries and compare their outputs byte for byte."
    )
    parser.add_argument("--before", required=True, metavar="BIN_A", help="the binary before the change")
    parser.add_argument("--after", required=True, metavar="BIN_B", help="the binary after the change")
    parser.add_argument("--work", default="same-outputs", metavar="DIR",
                        help="where runs, caches and summary.json go (default: ./same-outputs)")
    parser.add_argument("--studies", nargs="+", metavar="STUDY",
                        help="study files (default: every pipelines/**/*.yaml)")
    parser.add_argument("--skip", nargs="+", default=[], metavar="STUDY",
                        help="studies left out, by path or stem")
    parser.add_argument("--phase", choices=("before", "after", "both"), default="both")
    parser.add_argument("--reference", metavar="DIR",
                        help="the work folder holding the reference, its before/ and studies/ "
                             "(default: WORK)")
    parser.add_argument("--rev", default="HEAD",
                        help="the git revision whose pipelines/ both sides run (default: HEAD); "
                             "read when the reference is made, then kept in WORK/studies/")
    parser.add_argument("--after-rev", metavar="REV",
                        help="the git revision whose pipelines/ the after side runs "
                             "(default: the reference's)")
    parser.add_argument("--renamed", nargs="+", default=[], metavar="OLD=NEW",
                        help="the after side runs study NEW for the reference's OLD")
    parser.add_argument("--timeout", type=float, metavar="MINUTES",
                        help="stop a run after this many minutes (default: no limit)")
    args = parser.parse_args()

    binaries = {}
    for side, arg in (("before", args.before), ("after", args.after)):
        path = Path(arg).resolve()
        if not (path.is_file() and os.access(path, os.X_OK)):
            fail_usage(f"--{side} {arg}: not an executable file")
        binaries[side] = str(path)
    work = Path(args.work).resolve()
    reference = Path(args.reference).resolve() if args.reference else work
    side_dirs = {"before": reference / "before", "after": work / "after"}
    root = reference / "studies"
    timeout_s = args.timeout * 60 if args.timeout else None

    if args.phase != "after" and args.reference:
        fail_usage("--reference is for --phase after: a reference is made in WORK")
    sides = {"before": ["before"], "after": ["after"], "both": ["before", "after"]}[args.phase]
    studies_from = snapshot(root, args.rev, making="before" in sides)
    print(f"studies: pipelines/ of {studies_from['commit']} (tree {studies_from['tree']}), "
          f"copied to {root}", flush=True)
    after_root = root
    if args.after_rev:
        if args.phase == "before":
            fail_usage("--after-rev is for --phase after or both")
        after_from = snapshot_after(work / "studies-after", args.after_rev)
        after_root = work / "studies-after"
        print(f"after side: pipelines/ of {after_from['commit']}, copied to {after_root}", flush=True)
    renamed = {}
    for pair in args.renamed:
        old, sep, new = pair.partition("=")
        if not sep:
            fail_usage(f"--renamed {pair}: OLD=NEW")
        renamed[study_path(old, root)] = new
    studies = [study_path(arg, root) for arg in args.studies] if args.studies else default_studies(root)
    skip = set(args.skip)

    def skipped(study):
        return any(k in (study, Path(study).stem, Path(study).name)
                   or Path(k).resolve() in ((REPO / study).resolve(), (root / study).resolve())
                   for k in skip)

    studies = [study for study in studies if not skipped(study)]
    stems = {}
    for study in studies:
        stems.setdefault(Path(study).stem, []).append(study)
    clashes = {stem: paths for stem, paths in stems.items() if len(paths) > 1}
    if clashes:
        fail_usage(f"studies with the same stem (their folders would clash): {clashes}")
    if not studies:
        fail_usage("no study selected")

    comparing = args.phase != "before"
    results, all_ok = [], True
    totals = {"compared": 0, "identical": 0, "differing": 0, "only_one_side": 0,
              "timing_dependent_differing": 0}
    for study in studies:
        stem = Path(study).stem
        after_study = renamed.get(study, study)
        if not (after_root / after_study).is_file():
            fail_usage(f"{study}: no {after_study} in the after side's studies {after_root} "
                       "(removed? name what replaced it: --renamed OLD=NEW)")
        edited = (root / study).read_bytes() != (after_root / after_study).read_bytes()
        records = {}
        for side in SIDES:
            if side in sides:
                side_study, side_root = (study, root) if side == "before" else (after_study, after_root)
                records[side] = run_side(side, binaries[side], side_study, stem, side_dirs[side],
                                         side_root, timeout_s)
            else:
                records[side] = load_record(side_dirs[side] / stem)
        entry = {"study": study, "stem": stem, "before": records["before"], "after": records["after"]}
        times = f"{seconds_text(records['before'])}/{seconds_text(records['after'])}"
        if not comparing:
            record = records["before"]
            finished = record is not None and not record.get("timed_out") and record.get("exit_code") is not None
            all_ok &= finished
            files = len(outputs(side_dirs["before"] / stem / "out"))
            print(f"{stem}: before ran: exit {exit_text(record)}, {seconds_text(record)}, {files} output files",
                  flush=True)
            entry["output_files"] = files
            results.append(entry)
            continue
        timed = set()
        for record in records.values():
            timed |= set((record or {}).get("timing_stages") or [])
        result = compare(side_dirs["before"] / stem / "out", side_dirs["after"] / stem / "out", timed)
        result["timing_dependent_stages"] = sorted(timed)
        finished = all(r is not None and not r.get("timed_out") and r.get("exit_code") is not None
                       for r in records.values())
        same_exit = finished and records["before"]["exit_code"] == records["after"]["exit_code"]
        # An edited study may add outputs; it may not lose or change one.
        result["edited_study"] = edited and after_study
        same = (same_exit and not result["differing"] and not result["only_before"]
                and (edited or not result["only_after"]))
        result["same_exit"] = same_exit
        result["same"] = same
        entry["comparison"] = result
        results.append(entry)
        all_ok &= same
        for key in ("compared", "identical"):
            totals[key] += result[key]
        totals["differing"] += len(result["differing"])
        totals["timing_dependent_differing"] += len(result["timing_dependent_differing"])
        totals["only_one_side"] += len(result["only_before"]) + len(result["only_after"])
        line = (f"{stem}: {'SAME' if same else 'DIFFERENT'}: {result['compared']} files compared, "
                f"{result['identical']} identical, {len(result['differing'])} differing")
        if result["differing"]:
            line += f" [{listed(result['differing'])}]"
        if result["timing_dependent_differing"]:
            line += (f"; {len(result['timing_dependent_differing'])} timing-dependent differing, allowed "
                     f"[{listed(result['timing_dependent_differing'])}]")
        if result["only_before"]:
            line += f"; only before: {len(result['only_before'])} [{listed(result['only_before'])}]"
        if result["only_after"]:
            allowed = f", new in the edited study {after_study}, allowed" if edited else ""
            line += f"; only after{allowed}: {len(result['only_after'])} [{listed(result['only_after'])}]"
        line += f"; exit {exit_text(records['before'])}/{exit_text(records['after'])}; {times}"
        print(line, flush=True)

    n_same = sum(1 for entry in results if entry.get("comparison", {}).get("same"))
    seconds = {side: round(sum((e[side] or {}).get("seconds", 0.0) for e in results), 1) for side in SIDES}
    if comparing:
        total = (f"total: {len(results)} studies, {n_same} same, {len(results) - n_same} different; "
                 f"{totals['compared']} files compared, {totals['identical']} identical, "
                 f"{totals['differing']} differing, {totals['only_one_side']} on one side only, "
                 f"{totals['timing_dependent_differing']} timing-dependent differing (allowed); "
                 f"run time {seconds['before']:.1f} s before, {seconds['after']:.1f} s after")
    else:
        total = (f"total: {len(results)} studies run before, "
                 f"{sum(1 for e in results if exit_text(e['before']) == '0')} exited 0; "
                 f"run time {seconds['before']:.1f} s")
    print(total, flush=True)
    summary = {
        "phase": args.phase,
        "binaries": binaries,
        "work": str(work),
        "reference": str(reference),
        "studies_from": studies_from,
        "skipped": sorted(skip),
        "studies": results,
        "total": {**totals, "studies": len(results), "same": n_same if comparing else None,
                  "seconds": seconds, "ok": all_ok},
    }
    work.mkdir(parents=True, exist_ok=True)
    (work / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
