#!/usr/bin/env python3
"""Issue 19, "Seeds everywhere": the command line from 1,000 seeds spread through the lumen or
structure of every real scan in the shared data, each run held to the promise that it ends with a
valid mesh or a clear error, never a panic, a crash, a hang or a mesh that fails `check --strict`.

Where the seeds come from. Every documented seed (vmtk-aorta and vtk-carotid from the data
README, the others from each folder's meta.json) stands for one structure: 17 in all. Each
structure's region is its reference label where one exists (the aorta's level set < 0; the
`label_*.nii.gz` the data README names for that seed, in LABELS below), otherwise the balloon's own
result from the documented seed with the defaults, voxelised on the scan's grid as the sign of
`balloonseg distance` (exact for any direction matrix). Two seeds of one label (the fistula's
main vein and thin arm) split it between them, each voxel going to the nearer seed (world mm).
Seeds are drawn uniformly, without replacement and with a fixed RNG seed, among the region's
voxels at least 1.5 voxel diagonals deep (a Euclidean distance transform in mm, honouring the
spacing, with the volume's faces counting as border): deep enough to be in the lumen, not on its
wall. Where a thin region has fewer such voxels than it needs seeds, the bar drops to the depth
of its count-th deepest voxel (the draw stays uniform among all voxels that deep), and the table
shows the bar each structure got.

The split: 1,000 seeds over 17 structures, as evenly as they go: 59 each for the first 14 and
58 each for the last three, in the table's order (vmtk-aorta, vtk-carotid, then the meta.json
folders alphabetically, so vsseg001_head_t1gd's basilar artery, sinus and schwannoma get 58).

Each run is `balloonseg segment IMAGE --index --seed i,j,k -o OUT.vtp --stats RUN.json
--threads 1` with the defaults otherwise, under a wall-clock timeout and `ulimit -v` 4 GiB
(RLIMIT_AS), then `balloonseg check OUT.vtp --strict` when it succeeded. The timeout is 300 s
by default, not less: a seed whose balloon fills the soft tissue of ircad17 (about a million
triangles) ends validly after about 140 s on one thread, and that is slow, not a hang; the
table counts the runs over 120 s apart. Outcomes:
  valid         exit 0 and check --strict passes;
  clear error   non-zero exit with a message on stderr, no panic, no signal;
  and the failures: panic (exit 101 or "panicked" on stderr), crash (killed by a signal: an
  abort on a failed allocation is one), timeout, invalid mesh (check --strict fails), no message
  (non-zero exit with nothing said).
Two runs at a time (the machine has two cores). The seconds are wall-clock on a shared machine:
a sign of a slow seed, not a benchmark.

Usage: .venv/bin/python scripts/seed_sweep_lumen.py [--binary B] [--out seed_sweep_lumen.md]
       [--limit N] [--timeout S]
--limit N runs only the first N seeds of each structure (a quick check); the seeds are the
same as in the full sweep. Needs numpy, scipy and SimpleITK.
"""

import argparse
import json
import os
import re
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter, defaultdict

import numpy as np
import SimpleITK as sitk
from scipy import ndimage

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOTAL_SEEDS = 1000
RNG_SEED = 19
DEPTH_DIAGONALS = 1.5
MEMORY_LIMIT = 4 << 30
SLOW_SECONDS = 120

# The reference label of each documented seed (the data README's "must show" column).
LABELS = {
    ("ircad17_liver_cect", "aorta"): "label_artery.nii.gz",
    ("ircad17_liver_cect", "portal_vein"): "label_portalvein.nii.gz",
    ("ircad17_liver_cect", "ivc"): "label_venoussystem.nii.gz",
    ("ircad17_liver_cect", "liver"): "label_liver.nii.gz",
    ("ts_abdomen_slab_ct", "aorta"): "label_aorta.nii.gz",
    ("ts_abdomen_slab_ct", "liver"): "label_liver.nii.gz",
    ("ts_abdomen_slab_ct", "portal_vein"): "label_portal_splenic_vein.nii.gz",
    ("avf_arm_mra", "main_vein"): "label_reference_surface.nii.gz",
    ("avf_arm_mra", "branch"): "label_reference_surface.nii.gz",
}


def structures(data):
    """(scan, tag, image path, seed ijk, reference: a label file, a level set or None)."""
    found = [("vmtk-aorta", "aorta", "vmtk-aorta/aorta.mha", (74, 150, 15),
              "vmtk-aorta/aorta-reference-levelset.mha"),
             ("vtk-carotid", "r_ica", "vtk-carotid/carotid.mha", (17, 23, 8), None)]
    for scan in sorted(os.listdir(data)):
        meta_path = os.path.join(data, scan, "meta.json")
        if not os.path.isfile(meta_path):
            continue
        with open(meta_path) as f:
            meta = json.load(f)
        for seed in meta["seeds"]:
            label = LABELS.get((scan, seed["tag"]))
            found.append((scan, seed["tag"], os.path.join(scan, meta["image"]),
                          tuple(seed["ijk"]), label and os.path.join(scan, label)))
    return found


def run_checked(args):
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{shlex.join(map(str, args))} failed:\n{done.stderr}")


def region(binary, data, image_path, seed, reference, scratch):
    """The structure's voxels on the image's grid, as a boolean (z, y, x) array."""
    image = sitk.ImageFileReader()
    image.SetFileName(os.path.join(data, image_path))
    image.ReadImageInformation()
    if reference is None:
        mesh = os.path.join(scratch, "documented.vtp")
        distance = os.path.join(scratch, "documented_distance.nii.gz")
        run_checked([binary, "segment", os.path.join(data, image_path), "--index", "--seed",
                     ",".join(map(str, seed)), "-o", mesh])
        run_checked([binary, "distance", mesh, "--like", os.path.join(data, image_path),
                     "-o", distance])
        mask_image, inside = sitk.ReadImage(distance), lambda a: a < 0
    elif reference.endswith("levelset.mha"):
        mask_image, inside = sitk.ReadImage(os.path.join(data, reference)), lambda a: a < 0
    else:
        mask_image, inside = sitk.ReadImage(os.path.join(data, reference)), lambda a: a > 0
    if (mask_image.GetSize() != image.GetSize()
            or not np.allclose(mask_image.GetSpacing(), image.GetSpacing(), atol=1e-4)
            or not np.allclose(mask_image.GetOrigin(), image.GetOrigin(), atol=1e-3)):
        sys.exit(f"{reference or 'the documented result'} is not on {image_path}'s grid")
    return image, inside(sitk.GetArrayFromImage(mask_image))


def depth_mm(mask, spacing):
    """Distance (mm) of each voxel of the mask to the nearest voxel outside it or outside the
    volume (the padding makes the volume's faces border)."""
    padded = np.pad(mask, 1)
    depth = ndimage.distance_transform_edt(padded, sampling=spacing[::-1])
    return depth[1:-1, 1:-1, 1:-1]


def world(image, ijk):
    """World mm of voxel indices (n, 3), i fastest."""
    direction = np.array(image.GetDirection()).reshape(3, 3)
    return np.array(image.GetOrigin()) + (ijk * np.array(image.GetSpacing())) @ direction.T


def draw_seeds(binary, data, found, rng):
    """Every structure with its drawn seeds: dicts of scan, tag, image, seeds, depth_mm."""
    counts = [TOTAL_SEEDS // len(found) + (n < TOTAL_SEEDS % len(found))
              for n in range(len(found))]
    regions = {}
    with tempfile.TemporaryDirectory(prefix="seed-sweep-region-") as scratch:
        for scan, tag, image_path, seed, reference in found:
            key = (image_path, reference or f"result:{tag}")
            if key not in regions:
                regions[key] = region(binary, data, image_path, seed, reference, scratch)
    drawn = []
    for (scan, tag, image_path, seed, reference), count in zip(found, counts):
        image, mask = regions[(image_path, reference or f"result:{tag}")]
        depth = depth_mm(mask, image.GetSpacing())
        zyx = np.argwhere(mask)
        ijk = zyx[:, ::-1]
        # A label that several documented seeds share goes to the nearer seed, voxel by voxel.
        sharing = [s for _, _, p, s, r in found
                   if r is not None and (p, r) == (image_path, reference)]
        if len(sharing) > 1:
            points = world(image, ijk.astype(float))
            nearest = np.argmin([np.linalg.norm(points - world(image, np.array([s], float)),
                                                axis=1) for s in sharing], axis=0)
            keep = nearest == sharing.index(seed)
            zyx, ijk = zyx[keep], ijk[keep]
        depths = depth[tuple(zyx.T)]
        wanted = DEPTH_DIAGONALS * float(np.linalg.norm(image.GetSpacing()))
        # A thin structure has too few voxels that deep: the bar drops to the depth of its
        # count-th deepest voxel, and the draw stays uniform among all voxels that deep.
        least = min(wanted, float(np.sort(depths)[-count]))
        deep = np.flatnonzero(depths >= least)
        chosen = rng.choice(deep, size=count, replace=False)
        drawn.append({"scan": scan, "tag": tag, "image": os.path.join(data, image_path),
                      "seeds": [tuple(int(v) for v in ijk[n]) for n in chosen],
                      "depth_mm": least, "wanted_mm": wanted, "deep_voxels": len(deep),
                      "from": "reference" if reference else "balloon from the documented seed"})
    return drawn


def limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def error_kind(message):
    """A message's kind: its first clause, without numbers, brackets or the object's label."""
    text = re.sub(r"^object \d+: ", "", message)
    text = re.split(r"[:;]", text, maxsplit=1)[0]
    text = re.sub(r"\[[^\]]*\]|\([^)]*\)", "", text)
    text = re.sub(r"[-+]?\d[\d.,eE+-]*", "#", text)
    return re.sub(r"\s+", " ", text).strip()


class Run:
    """One seed: `segment`, then `check --strict` when it succeeded, as non-blocking stages."""

    def __init__(self, binary, structure, seed, workdir, timeout):
        self.structure, self.seed, self.timeout = structure, seed, timeout
        self.mesh = os.path.join(workdir, "out.vtp")
        self.segment_args = [binary, "segment", structure["image"], "--index", "--seed",
                             ",".join(map(str, seed)), "-o", self.mesh, "--stats",
                             os.path.join(workdir, "run.json"), "--threads", "1"]
        self.check_args = [binary, "check", self.mesh, "--strict"]
        self.command = shlex.join(self.segment_args[:6] + ["-o", "out.vtp", "--threads", "1"])
        self.workdir = workdir
        self.outcome = self.message = None
        self.started = time.monotonic()
        self.seconds = None
        self._start(self.segment_args)

    def _start(self, args):
        self.stage_started = time.monotonic()
        self.stdout = open(os.path.join(self.workdir, "stdout"), "w+")
        self.stderr = open(os.path.join(self.workdir, "stderr"), "w+")
        self.process = subprocess.Popen(args, stdout=self.stdout, stderr=self.stderr,
                                        stdin=subprocess.DEVNULL, preexec_fn=limit_memory)

    def _finish_stage(self):
        self.stdout.seek(0)
        self.stderr.seek(0)
        out, err = self.stdout.read(), self.stderr.read()
        self.stdout.close()
        self.stderr.close()
        return out, err

    def poll(self):
        """True when the run has its outcome."""
        if time.monotonic() - self.stage_started > self.timeout:
            self.process.kill()
            self.process.wait()
            self._finish_stage()
            stage = "segment" if self.seconds is None else "check"
            self.outcome, self.message = "timeout", f"{stage} still running after {self.timeout} s"
            return True
        code = self.process.poll()
        if code is None:
            return False
        out, err = self._finish_stage()
        if self.seconds is None:
            self.seconds = time.monotonic() - self.started
            self.outcome, self.message = classify(code, err)
            if self.outcome == "segmented":
                self._start(self.check_args)
                return False
            return True
        if code == 0:
            self.outcome = "valid"
        else:
            self.outcome = "invalid mesh"
            self.message = (err.strip() or out.strip()).replace("\n", " ")
        return True


def classify(code, stderr):
    if "panicked" in stderr or code == 101:
        return "panic", stderr.strip()
    if code < 0:
        return "crash", f"signal {-code}: {stderr.strip()}"
    if code == 0:
        return "segmented", None
    reasons = [line.split("error: ", 1)[1] for line in stderr.splitlines() if "error: " in line]
    if reasons:
        return "clear error", reasons[-1]
    return "no message", stderr.strip()


def sweep(binary, drawn, limit, timeout):
    # Two slots polled from this one thread rather than a thread pool: preexec_fn (the memory
    # limit) is not safe in a process that has threads.
    jobs = [(s, seed) for s in drawn for seed in s["seeds"][:limit]]
    done, running = [], []
    with tempfile.TemporaryDirectory(prefix="seed-sweep-runs-") as scratch:
        slots = [os.path.join(scratch, f"slot{n}") for n in range(2)]
        for slot in slots:
            os.mkdir(slot)
        free = list(slots)
        while jobs or running:
            while jobs and free:
                structure, seed = jobs.pop(0)
                running.append(Run(binary, structure, seed, free.pop(), timeout))
            for run in [r for r in running if r.poll()]:
                running.remove(run)
                free.append(run.workdir)
                for name in os.listdir(run.workdir):
                    os.remove(os.path.join(run.workdir, name))
                done.append(run)
                if run.outcome not in ("valid", "clear error"):
                    print(f"{run.outcome}: {run.command}\n  {run.message}", file=sys.stderr)
                if len(done) % 50 == 0:
                    print(f"{len(done)} runs", file=sys.stderr)
            time.sleep(0.02)
    return done


FAILURES = ("panic", "crash", "timeout", "invalid mesh", "no message")


def report(drawn, runs, timeout, wall):
    by_structure = defaultdict(list)
    for run in runs:
        by_structure[(run.structure["scan"], run.structure["tag"])].append(run)
    lines = [
        f"`scripts/seed_sweep_lumen.py` (RNG seed {RNG_SEED}): `balloonseg segment IMAGE --index "
        "--seed i,j,k --threads 1` with the defaults, then `check --strict`. Seeds drawn "
        "uniformly among the voxels of the structure at least \"depth\" mm from its border "
        "(wanted: 1.5 voxel diagonals); seconds are wall-clock per run, two runs at a time.",
        "",
        "| scan | structure | seeds from | depth ≥ mm | seeds | valid | clear errors | failures "
        f"| median s | max s | over {SLOW_SECONDS} s |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    totals = Counter()
    for s in drawn:
        rs = by_structure[(s["scan"], s["tag"])]
        if not rs:
            continue
        outcomes = Counter(r.outcome for r in rs)
        totals.update(outcomes)
        kinds = Counter(error_kind(r.message) for r in rs if r.outcome == "clear error")
        errors = "; ".join(f"{n} × {k}" for k, n in kinds.most_common()) or "0"
        failures = ", ".join(f"{outcomes[f]} {f}" for f in FAILURES if outcomes[f]) or "0"
        seconds = [r.seconds for r in rs if r.seconds is not None]
        lines.append(
            f"| {s['scan']} | {s['tag']} | {s['from']} | {s['depth_mm']:.2f} | {len(rs)} "
            f"| {outcomes['valid']} | {errors} | {failures} "
            f"| {statistics.median(seconds) if seconds else float('nan'):.1f} "
            f"| {max(seconds) if seconds else float('nan'):.1f} "
            f"| {sum(t > SLOW_SECONDS for t in seconds)} |")
    failed = sum(totals[f] for f in FAILURES)
    lines.append(
        f"| **total** | | | | {len(runs)} | {totals['valid']} | {totals['clear error']} "
        f"| {failed} | | | {sum(r.seconds is not None and r.seconds > SLOW_SECONDS for r in runs)} "
        "|")
    lines += [
        "",
        f"{len(runs)} runs: {totals['valid']} valid, {totals['clear error']} clear errors, "
        f"{failed} failures ({', '.join(f'{totals[f]} {f}' for f in FAILURES)}). "
        f"Timeout {timeout} s, `ulimit -v` {MEMORY_LIMIT >> 30} GiB, two runs at a time, "
        f"{wall / 60:.0f} min in all (wall-clock on a shared two-core machine).",
        "",
        "Error messages, the first three of each kind:",
        "",
    ]
    kinds = defaultdict(list)
    for run in runs:
        if run.outcome == "clear error":
            kinds[error_kind(run.message)].append(run)
    for kind, rs in sorted(kinds.items(), key=lambda item: -len(item[1])):
        lines.append(f"- {kind} ({len(rs)}):")
        for run in rs[:3]:
            lines.append(f"  - {run.structure['scan']} {run.seed}: {run.message}")
    failures = [r for r in runs if r.outcome in FAILURES]
    if failures:
        lines += ["", "Failures, each with its command:", ""]
        for run in failures:
            lines.append(f"- {run.outcome}: `{run.command}`: {run.message}")
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--binary", default=os.path.join(ROOT, "target/release/balloonseg"))
    parser.add_argument("--data", default=os.environ.get("BALLOONSEG_DATA")
                        or os.path.join(ROOT, "..", "shared", "data"))
    parser.add_argument("--out", default="seed_sweep_lumen.md")
    parser.add_argument("--limit", type=int, help="seeds per structure (default: all)")
    parser.add_argument("--timeout", type=float, default=300.0, help="seconds per run")
    args = parser.parse_args()
    data = os.path.abspath(args.data)
    binary = os.path.abspath(args.binary)
    drawn = draw_seeds(binary, data, structures(data), np.random.default_rng(RNG_SEED))
    for s in drawn:
        print(f"{s['scan']} {s['tag']}: {len(s['seeds'])} seeds among {s['deep_voxels']} voxels "
              f"≥ {s['depth_mm']:.2f} mm deep (wanted {s['wanted_mm']:.2f}; {s['from']})",
              file=sys.stderr)
    started = time.monotonic()
    runs = sweep(binary, drawn, args.limit, args.timeout)
    text = report(drawn, runs, args.timeout, time.monotonic() - started)
    with open(args.out, "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
