#!/usr/bin/env python3
"""Mutation campaign against the strandmesh CLI (docs/reliability.md).

Mutates seed files (skeletons or meshes) and runs each through the given strandmesh binary
(ideally the sanitizer build, build-asan/strandmesh), in a fresh folder, with a time limit.
Every run is classified: exit 0 / 1 / 2 / 4 are answers; exit 3 (internal error), a signal,
a sanitizer report ("ERROR: AddressSanitizer", "runtime error:") or the time limit are
findings, and so is a rejection (exit 1) whose message does not name the input file. Every
other glTF mesh is checked at its level of detail 1 (`check --lod 1`).
Findings are copied to OUT/findings/. Deterministic for a seed. With --reference (the
Release binary), a sanitizer run over the limit counts as a hang only if the Release binary
also takes longer; otherwise it is rerun under the sanitizers with --sanitizer-timeout.

  scripts/mutation_campaign.py --binary build-asan/strandmesh --reference build/strandmesh --kind skeleton --count 3000 \\
      --seeds tests/data/skeletons fuzz/corpus/skeleton_json fuzz/corpus/skeleton_swc --out /tmp/campaign
  scripts/mutation_campaign.py --binary build-asan/strandmesh --kind mesh --count 1000 \\
      --seeds fuzz/corpus/mesh_glb fuzz/corpus/mesh_gltf fuzz/corpus/mesh_obj fuzz/corpus/mesh_ply --out /tmp/campaign
"""
import argparse
import collections
import concurrent.futures
import json
import os
import random
import re
import shutil
import subprocess
import sys

EXTREMES = [b"0", b"-0", b"-1", b"1e6", b"-1e7", b"1e12", b"1e100", b"-1e200", b"1e308", b"-1e308", b"1e-320",
            b"4294967295", b"4294967296", b"18446744073709551615", b"9007199254740993", b"NaN", b"nan", b"inf",
            b"-inf", b"1e999", b"0.000000001", b"123456789012345678901234567890", b"\"x\"", b"null", b"true",
            b"[]", b"{}", b"[[[[[[[[1]]]]]]]]"]
NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def mutate(data: bytes, rng: random.Random, kind: str) -> bytes:
    b = bytearray(data)
    for _ in range(rng.choice([1, 1, 1, 2, 3, 5])):
        op = rng.randrange(11)
        if not b:
            b = bytearray(rng.randbytes(rng.randrange(1, 64)))
            continue
        i = rng.randrange(len(b))
        if op == 0:  # flip bits
            for _ in range(rng.randrange(1, 8)):
                j = rng.randrange(len(b))
                b[j] ^= 1 << rng.randrange(8)
        elif op == 1:  # random bytes in
            b[i:i] = rng.randbytes(rng.randrange(1, 16))
        elif op == 2:  # delete a chunk
            del b[i:i + rng.randrange(1, max(2, len(b) // 8))]
        elif op == 3:  # duplicate a chunk
            n = rng.randrange(1, max(2, min(4096, len(b) // 4)))
            b[i:i] = b[i:i + n]
        elif op == 4:  # truncate
            del b[i:]
        elif op in (5, 6, 7):  # a number replaced by an extreme one
            nums = list(NUMBER.finditer(bytes(b)))
            if nums:
                m = rng.choice(nums)
                b[m.start():m.end()] = rng.choice(EXTREMES)
        elif op == 8:  # deep nesting
            depth = rng.choice([200, 5000, 100000])
            b[i:i] = b"[" * depth + b"1" + b"]" * depth
        elif op == 9:  # a long run of one byte
            b[i:i] = bytes([rng.randrange(256)]) * rng.choice([100, 10000, 200000])
        else:  # overwrite 4 bytes with an extreme integer (binary formats)
            v = rng.choice([0, 1, 0x7FFFFFFF, 0xFFFFFFFF, 0x80000000, 0x10000, rng.randrange(1 << 32)])
            b[i:i + 4] = v.to_bytes(4, "little")
    return bytes(b)


def classify(code, err, timed_out, name):
    if timed_out:
        return "hang"
    if "ERROR: AddressSanitizer" in err or "ERROR: LeakSanitizer" in err or "runtime error:" in err:
        return "sanitizer"
    if code < 0:
        return "signal"
    if code == 3:
        return "exit 3"
    if code == 1 and name + ":" not in err:  # "case000001.json: nodes[3] ..." or "case000001.json:12:5: ..."
        return "unnamed rejection"
    return "exit %d" % code


slow_runs = []  # runs over --timeout under the sanitizers that the reference build finished in time


def run_one(args, k, seed_path, out_root):
    rng = random.Random(args.seed * 1_000_003 + k)
    data = open(seed_path, "rb").read()
    mutated = mutate(data, rng, args.kind)
    ext = os.path.splitext(seed_path)[1]
    work = os.path.join(out_root, "work", "%06d" % k)
    os.makedirs(work, exist_ok=True)
    name = "case%06d%s" % (k, ext)
    path = os.path.join(work, name)
    with open(path, "wb") as f:
        f.write(mutated)
    if args.kind == "skeleton":
        cmd = [args.binary, "info", path]
        if args.mesh_every and k % args.mesh_every == 0:
            cmd = [args.binary, "-q", "mesh", path, "-o", os.path.join(work, "out.glb")]
    else:
        cmd = [args.binary, "check", path]
        if ext in (".glb", ".gltf") and k % 2 == 1:  # every other glTF: its level of detail 1 (MSFT_lod)
            cmd = [args.binary, "check", "--lod", "1", path]
    def attempt(binary, timeout):
        try:
            p = subprocess.run([binary] + cmd[1:], capture_output=True, timeout=timeout, cwd=work)
            return p.returncode, p.stderr.decode("utf-8", "replace"), False
        except subprocess.TimeoutExpired as e:
            return None, (e.stderr or b"").decode("utf-8", "replace"), True

    code, err, timed_out = attempt(args.binary, args.timeout)
    slow = False
    if timed_out and args.reference:
        # The sanitizers make a run 2-5 times slower: an input the optimized build (--reference)
        # finishes within the limit is no hang. It then gets --sanitizer-timeout to finish under
        # the sanitizers, so that its sanitizer verdict is not lost.
        _, _, ref_timed_out = attempt(args.reference, args.timeout)
        if not ref_timed_out:
            slow = True
            code, err, timed_out = attempt(args.binary, args.sanitizer_timeout)
    outcome = classify(code, err, timed_out, name)
    if slow and not timed_out:
        slow_runs.append(k)
    finding = outcome in ("hang", "sanitizer", "signal", "exit 3", "unnamed rejection")
    if finding:
        dest = os.path.join(out_root, "findings")
        os.makedirs(dest, exist_ok=True)
        shutil.copy(path, os.path.join(dest, name))
        with open(os.path.join(dest, name + ".txt"), "w") as f:
            f.write(" ".join(cmd) + "\n" + outcome + "\n" + err[-20000:])
    shutil.rmtree(work, ignore_errors=True)
    # The rule a rejection names, with the place and numbers blanked, for the summary.
    rule = None
    if outcome == "exit 1":
        line = next((l for l in err.splitlines() if name in l), "")
        rule = re.sub(r"-?\d[\d.e+-]*", "N", line.split(name, 1)[-1])[:100]
    command = {"-q": "mesh", "check": "check --lod 1" if "--lod" in cmd else "check"}.get(cmd[1], cmd[1])
    return command, outcome, finding, rule


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", required=True)
    ap.add_argument("--kind", choices=["skeleton", "mesh"], required=True)
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--seeds", nargs="+", required=True, help="files or folders of seed inputs")
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=60)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--reference", help="optimized binary: a sanitizer run over --timeout is a hang only if this one is too")
    ap.add_argument("--sanitizer-timeout", type=float, default=600,
                    help="limit for a sanitizer run the reference finished within --timeout (s)")
    ap.add_argument("--mesh-every", type=int, default=10, help="skeletons: every Nth goes through `mesh` (0: none)")
    args = ap.parse_args()
    args.binary = os.path.abspath(args.binary)  # runs happen in their own folders
    exts = {"skeleton": (".json", ".swc", ".csv", ".txt", ".mtg", ".mat"),
            "mesh": (".glb", ".gltf", ".obj", ".ply")}[args.kind]
    seeds = []
    for s in args.seeds:
        if os.path.isdir(s):
            seeds += sorted(os.path.join(s, f) for f in os.listdir(s) if f.endswith(exts))
        elif os.path.isfile(s):
            seeds.append(s)
    if not seeds:
        sys.exit("no seed files")
    os.makedirs(args.out, exist_ok=True)
    # A copy, so that rebuilding during the campaign does not pull the binary away under it.
    copy = os.path.join(args.out, "strandmesh-under-test")
    shutil.copy2(args.binary, copy)
    args.binary = copy
    if args.reference:
        ref = os.path.join(args.out, "strandmesh-reference")
        shutil.copy2(os.path.abspath(args.reference), ref)
        args.reference = ref
    table = collections.Counter()
    rules = collections.Counter()
    findings = 0
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        # Seeds drawn at random (fixed for --seed), so that every Nth run through `mesh` does not
        # always get the same few seeds.
        pick = random.Random(args.seed)
        futures = [pool.submit(run_one, args, k, seeds[pick.randrange(len(seeds))], args.out) for k in range(args.count)]
        for f in concurrent.futures.as_completed(futures):
            command, outcome, finding, rule = f.result()
            table[(command, outcome)] += 1
            findings += finding
            if rule is not None:
                rules[rule] += 1
    summary = {"kind": args.kind, "runs": args.count, "seeds": len(seeds), "findings": findings,
               "outcomes": {"%s: %s" % k: v for k, v in sorted(table.items())},
               "slow under the sanitizers (over %g s; the reference build within it)" % args.timeout: len(slow_runs),
               "distinct rejections": len(rules), "most common rejections": dict(rules.most_common(25))}
    print(json.dumps(summary, indent=2))
    with open(os.path.join(args.out, "summary_%s.json" % args.kind), "w") as f:
        json.dump(summary, f, indent=2)
    sys.exit(1 if findings else 0)


if __name__ == "__main__":
    main()
