#!/usr/bin/env python3
"""Mutation fuzzer for the autonomsim command line (issue 15: never crash on input).

Takes the shipped scenarios (scenarios/*.yaml), the track (scenarios/tracks/lab.yaml) and the
platform profile (scenarios/platforms/zcu104.yaml), applies seeded random mutations (odd and
extreme scalars, invalid UTF-8, lists for mappings and back, deleted, duplicated and unknown keys,
deep nesting, YAML oddities; malformed `--set` paths and values; odd `--seed`s), writes each
mutant with copies of the track and profile into a folder of its own, runs

    autonomsim run MUTANT --out FOLDER/out -q --set duration_s=D [mutated --set/--seed ...]

(`--set duration_s` is left out when the mutation is about duration_s; the timeout caps the wall
time then) and classifies the outcome:

  ok         exit 0 or 1; or exit 2 whose message names where: `FILE:LINE:COL: KEY: ...` (FILE in
             the mutant's folder, LINE inside it) or, for command-line input, `--set KEY: ...`,
             `--seed ...`
  finding    anything else: a signal (abort, segfault), a timeout, another exit code, or an exit 2
             whose message lacks file, line or key (`exit2_no_key`: file and line but no key, e.g.
             syntax or UTF-8 errors; `exit2_unlocated`: neither)
  accepted   (a note, not a finding) exit 0/1 although an extreme value (nan, inf, 1e39, -1, ...)
             was put in: a validation gap to look at

Run it from a folder holding the binary and the scenarios, at low priority:

    mkdir -p /tmp/mutfuzz && cp -r build/bin scenarios /tmp/mutfuzz/
    cd /tmp/mutfuzz && nice -n 10 python3 "$OLDPWD"/tools/fuzz/mutate_scenarios.py \
        --bin bin/autonomsim --scenarios scenarios --out report --seed 1 --count 3000 --jobs 2

Results: OUT/summary.md and OUT/summary.json (counts per exit code, class and mutation kind; the
findings grouped by message), OUT/results.jsonl (one line per mutant). Each finding's folder is
kept as OUT/findings/<index>/ with cmd.sh to reproduce it. The same --seed gives the same mutants,
whatever --jobs; `--only N` runs mutant N alone.
"""
import argparse, collections, concurrent.futures, json, os, random, re, shlex, shutil, signal
import subprocess, sys, time
import yaml

class M(list): """A mapping as a list of [key bytes, value] pairs (so keys can repeat)."""
class S(list): """A sequence."""
class Raw(bytes): """A scalar, as the YAML text to write."""

NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
PLAIN = re.compile(r"^[A-Za-z0-9_./+-][A-Za-z0-9_ ./+-]*$")
EXTREMES = [b"1e39", b"-1e39", b"1e308", b"-1e308", b"1e-320", b"nan", b".nan", b"inf", b".inf",
            b"-.inf", b"-0", b"0", b"-1", b"18446744073709551616", b"9223372036854775807",
            b"-9223372036854775809", b"99999999999999999999999", b"4294967296", b'""', b"~",
            b"2147483648", b"0x7fffffff", b"1_000", b"1e", b"+.5", b"-0.0000001"]
NONSENSE = {b"1e39", b"-1e39", b"1e308", b"-1e308", b"nan", b".nan", b"inf", b".inf", b"-.inf",
            b"-1", b"18446744073709551616", b"9223372036854775807", b"-9223372036854775809",
            b"99999999999999999999999", b"4294967296", b"2147483648"}
NON_ASCII = ['"é"', '"日本語"', '"\U0001F697"', '"\u202eRTL"', '"a\u200bb"', '"e\u0301"',
             '"\\u0000"', '"\\t\\n"', '"' + "x" * 5000 + '"']
BAD_UTF8 = [b'"\xff"', b'"caf\xe9"', b"caf\xe9", b'"\xc3\x28"', b'"\xed\xa0\x80"',
            b'"\xf4\x90\x80\x80"', b'"\xc0\xaf"', b'"\xe2\x82"', b"\xfe\xff"]
OTHER_TYPES = [b'"fast"', b"true", b"false", b"42", b"0.5", b'"42"', b"sw", b"[1, 2]", b"{a: 1}"]
YAML_ODD = [b"*undefined", b"!!binary aGVsbG8=", b"!!int 1.5", b"!custom 3", b"!!float", b"'open",
            b'"\\x"', b"{a: 1, a: 2}", b"[1, [2, {b: }]]", b"&a [*a]", b"? [k]", b"- 1", b"a: b: c",
            b"{", b"]", b"%TAG", b"@x", b"`x", b"|"]
UNKNOWN_KEYS = [b"bogus", b"Duration_s", b'"\xc3\xa9t\xc3\xa9"', b'""', b"'a b'", b"x" * 300,
                b"'1'", b"~", b"[1, 2]", b"{k: v}"]
SET_VALUES = [b"1", b"x", b"sw", b"0.5", b"", b"{}", b"[]", b"{a: 1}", b"[1, 2]", b"{", b"[1,",
              b"*a", b"a: b: c", b"- x", b"\xff", b"caf\xe9", "é".encode(), b"=", b"1=2"]
SEEDS = [b"-1", b"1e3", b"18446744073709551616", b"18446744073709551615", b"", b"0x10", b" 5",
         b"5 ", b"+5", b"nan", b"\xff", b"99999999999999999999999999", b"0", b"007"]

def convert(node):
    """yaml.compose node -> M/S/Raw, keeping each scalar's text (so 1e-3 stays 1e-3)."""
    if isinstance(node, yaml.MappingNode):
        return M([[convert(k), convert(v)] for k, v in node.value])
    if isinstance(node, yaml.SequenceNode):
        return S(convert(v) for v in node.value)
    if node.style is None and (node.value == "" or PLAIN.match(node.value)):
        return Raw(node.value.encode())
    return Raw(json.dumps(node.value, ensure_ascii=False).encode())

def inline(v):
    return bytes(v) if isinstance(v, Raw) else (b"{}" if isinstance(v, M) else b"[]")

def emit(node, ind=0, out=None):
    """Block-style YAML, one key or list entry per line (so an error's line says something)."""
    out = [] if out is None else out
    pad = b" " * ind
    if isinstance(node, Raw) or not node:
        out.append(pad + inline(node))
    for item in node if isinstance(node, (M, S)) else []:
        head, v = (pad + item[0] + b":", item[1]) if isinstance(node, M) else (pad + b"-", item)
        if isinstance(v, Raw) or not v:
            out.append(head + b" " + inline(v))
        else:
            out.append(head)
            emit(v, ind + 2, out)
    return out

def sites(node, path=""):
    """Every (container, index, path) below node; holder [root] gives the top level index 0."""
    items = enumerate(node) if isinstance(node, (S, list)) and not isinstance(node, M) else []
    if isinstance(node, M):
        for i, (k, v) in enumerate(node):
            p = (path + "." if path else "") + k.decode("utf-8", "replace")
            yield node, i, p
            yield from sites(v, p)
    for i, v in items:
        p = path + f"[{i}]" if isinstance(node, S) else path
        yield node, i, p
        yield from sites(v, p)

def get(c, i): return c[i][1] if isinstance(c, M) else c[i]
def put(c, i, v):
    if isinstance(c, M): c[i][1] = v
    else: c[i] = v

def mutate_tree(rng, holder):
    """One mutation of the tree in holder[0]; returns (kind, path, value put in or None, old)."""
    all_sites = list(sites(holder))
    scal = [s for s in all_sites if isinstance(get(s[0], s[1]), Raw)]
    cont = [s for s in all_sites if isinstance(get(s[0], s[1]), (M, S))]
    maps = [s for s in cont if isinstance(get(s[0], s[1]), M)]
    entries = [s for s in all_sites if isinstance(s[0], M)]
    kind = rng.choice(["extreme_scalar"] * 4 + ["swap_type", "scalar_to_container",
                       "container_to_scalar", "map_to_list", "list_to_map", "delete_key",
                       "duplicate_key", "unknown_key", "non_ascii", "invalid_utf8",
                       "deep_nesting", "empty_container", "yaml_oddity"])
    if kind in ("container_to_scalar", "empty_container") and not cont: kind = "extreme_scalar"
    if kind in ("delete_key", "duplicate_key") and not entries: kind = "extreme_scalar"
    if kind == "unknown_key" and not maps: kind = "extreme_scalar"
    c, i, path = rng.choice({"container_to_scalar": cont, "empty_container": cont,
                             "map_to_list": cont, "list_to_map": cont, "delete_key": entries,
                             "duplicate_key": entries, "unknown_key": maps}.get(kind, scal)
                            or all_sites)  # e.g. no scalar left: the top level itself
    old, value = get(c, i), None
    if kind == "extreme_scalar": value = rng.choice(EXTREMES)
    elif kind == "swap_type": value = rng.choice(OTHER_TYPES)
    elif kind == "non_ascii": value = rng.choice(NON_ASCII).encode()
    elif kind == "invalid_utf8": value = rng.choice(BAD_UTF8)
    elif kind == "yaml_oddity": value = rng.choice(YAML_ODD)
    elif kind == "container_to_scalar": value = rng.choice(EXTREMES + OTHER_TYPES[:4])
    elif kind == "deep_nesting":
        n = rng.choice([64, 1000, 20000])
        value = rng.choice([b"[" * n + b"]" * n, b"{a: " * n + b"1" + b"}" * n])
    elif kind == "scalar_to_container":
        put(c, i, rng.choice([M(), S(), S([old]), M([[b"a", old]])]))
    elif kind == "map_to_list":
        put(c, i, S(v for _, v in old) if isinstance(old, M) else S([old]))
    elif kind == "list_to_map":
        put(c, i, M([[str(j).encode(), v] for j, v in enumerate(old)]) if isinstance(old, S)
             else M([[b"a", old]]))
    elif kind == "empty_container": put(c, i, type(old)())
    elif kind == "delete_key": del c[i]
    elif kind == "duplicate_key":
        dup = old if rng.random() < 0.5 else Raw(rng.choice(EXTREMES + OTHER_TYPES))
        c.insert(rng.choice([i + 1, len(c)]), [c[i][0], dup])
    elif kind == "unknown_key":
        key = rng.choice(UNKNOWN_KEYS + [b"x" + k for k, _ in old][:3])
        old.insert(rng.randrange(len(old) + 1), [key, Raw(rng.choice(OTHER_TYPES))])
    if value is not None: put(c, i, Raw(value))
    return kind, path, value, old

def leaf_paths(node):
    return [(p, get(c, i)) for c, i, p in sites([node]) if p and isinstance(get(c, i), Raw)]

def corrupt_path(rng, p):
    return rng.choice([
        lambda: p.replace("[", ".", 1).replace("]", "", 1), lambda: p.replace("]", "", 1),
        lambda: p.replace("]", "]]", 1), lambda: "." + p, lambda: p + ".", lambda: p + "..x",
        lambda: p.replace(".", "..", 1), lambda: re.sub(r"\[\d+\]", "[-1]", p, 1),
        lambda: re.sub(r"\[\d+\]", "[99999999999999999999]", p, 1),
        lambda: re.sub(r"\[\d+\]", "[4294967296]", p, 1), lambda: re.sub(r"\[\d+\]", "[]", p, 1),
        lambda: re.sub(r"\[\d+\]", "[7]", p, 1), lambda: re.sub(r"\[\d+\]", "[0x1]", p, 1),
        lambda: "[0]." + p, lambda: p + "[0]", lambda: p + ".extra", lambda: " " + p,
        lambda: p.replace(".", " . ", 1), lambda: "é." + p, lambda: ".".join(["a"] * 3000),
        lambda: p.upper(), lambda: p + "[0", lambda: "", lambda: "=", lambda: "a=b=c"])()

def make_case(rng, base, files, case):
    """Writes one mutant into `case`; returns (argv tail, record)."""
    name = rng.choice(sorted(files["scenarios"]))
    target = rng.choices(["scenario", "track", "set", "platform", "seed"], [50, 20, 20, 6, 4])[0]
    texts = {name: files["scenarios"][name], "tracks/lab.yaml": files["track"],
             "platforms/zcu104.yaml": files["platform"]}
    tree_file = {"scenario": name, "track": "tracks/lab.yaml",
                 "platform": "platforms/zcu104.yaml"}.get(target)
    args, muts = [], []
    for _ in range(1 if rng.random() < 0.8 else rng.randint(2, 3)):
        if tree_file:
            holder = [convert(yaml.compose(texts[tree_file].decode()))] if isinstance(
                texts[tree_file], bytes) else texts[tree_file]
            kind, path, value, old = mutate_tree(rng, holder)
            texts[tree_file] = holder
        elif target == "seed":
            kind, path, value, old = "cli_seed", "--seed", rng.choice(SEEDS), None
            args += [b"--seed", value]
        else:
            tree = convert(yaml.compose(files["scenarios"][name].decode()))
            path, old = rng.choice(leaf_paths(tree))
            kind = rng.choice(["set_value", "set_path", "set_type", "set_new_key"])
            value = rng.choice(EXTREMES + OTHER_TYPES) if kind in ("set_value", "set_type") \
                else rng.choice(SET_VALUES)
            if kind == "set_path": path = corrupt_path(rng, path)
            if kind == "set_type": path = path.rsplit(".", 1)[0] if "." in path else path
            if kind == "set_new_key":
                path = rng.choice([path + ".bogus", path.rsplit(".", 1)[0] + ".bogus",
                                   "cars[0].platform.mapping.lane_detektion.target",
                                   "cars[0].platform.mapping.lane_detection.targte",
                                   "cars[0].platform.transport./points.transport", "bogus"])
            args += [b"--set", path.encode() + b"=" + value]
        muts.append({"kind": kind, "target": target, "path": path,
                     "value": None if value is None else value.decode("utf-8", "replace")[:80],
                     "old": old.decode("utf-8", "replace")[:40] if isinstance(old, Raw) else None})
    os.makedirs(os.path.join(case, "tracks")); os.makedirs(os.path.join(case, "platforms"))
    for rel, content in texts.items():
        with open(os.path.join(case, rel), "wb") as f:
            f.write(content if isinstance(content, bytes) else b"\n".join(emit(content[0])) + b"\n")
    if not any("duration" in str(m["path"]) for m in muts):
        args = [b"--set", b"duration_s=" + base.duration.encode()] + args
    return [os.path.join(case, name).encode(), b"--out", os.path.join(case, "out").encode(),
            b"-q"] + args, {"scenario": name, "mutations": muts}

LOCATED = re.compile(r"^error: (?P<file>[^:\n]+):(?P<line>\d+):(?P<col>\d+): "
                     r"(?!YAML syntax error: )(?P<key>[^:\n]+?)(?: \(with --set [^)]*\))?: \S", re.M)
FILE_LINE = re.compile(r"^error: (?P<file>[^:\n]+):(?P<line>\d+):(?P<col>\d+): ", re.M)
CLI = re.compile(r"^(error: )?--(set|seed)\b.*\S", re.M)

def classify(rc, err, case):
    if rc in (0, 1): return "ok"
    if rc != 2: return rc if isinstance(rc, str) else "exit_%d" % rc
    m = LOCATED.search(err) or FILE_LINE.search(err)
    if m:
        f = m["file"]
        if not os.path.realpath(f).startswith(os.path.realpath(case)) or not os.path.isfile(f):
            return "exit2_bad_file"
        with open(f, "rb") as fh:
            if not 1 <= int(m["line"]) <= fh.read().count(b"\n") + 1: return "exit2_bad_line"
        return "ok" if m.re is LOCATED else "exit2_no_key"
    return "ok" if CLI.search(err) else "exit2_unlocated"

def signature(cls, err, case, rec):
    line = next((l for l in err.splitlines() if l.strip()), "")[:300]
    if not cls.startswith("exit2"):  # a crash or hang: group by what was mutated, too
        m = rec["mutations"][0]
        line = f"{m['target']} {m['path']} {m['kind']}: {line}"  # digits become N below
    line = line.replace(case, "<case>")
    line = re.sub(r"'[^']*'", "'…'", line)
    return cls + ": " + re.sub(r"\d+(\.\d+)?", "N", line)[:200]

def run_one(base, files, index):
    rng = random.Random(f"{base.seed}:{index}")
    case = os.path.join(os.path.abspath(base.out), "work", str(index))
    shutil.rmtree(case, ignore_errors=True)
    try:
        argv, rec = make_case(rng, base, files, case)
    except Exception as e:  # a bug of this script: say so, keep going
        return {"index": index, "rc": "fuzzer_error", "cls": "fuzzer_error", "stderr": repr(e),
                "signature": "fuzzer_error: " + repr(e), "mutations": [], "scenario": None}
    cmd = [b"nice", b"-n", str(base.nice).encode(), os.path.abspath(base.bin).encode(),
           b"run"] + argv
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, cwd=os.getcwd(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         start_new_session=True)
    try:
        out, err = p.communicate(timeout=base.timeout)
        rc = p.returncode if p.returncode >= 0 else "signal_%d" % -p.returncode
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
        rc = "timeout"
    err = err.decode("utf-8", "replace")
    cls = classify(rc, err, case)
    rec.update(index=index, rc=rc, cls=cls, wall_s=round(time.monotonic() - t0, 2),
               stderr=err[-2000:], signature=None if cls == "ok" else signature(cls, err, case, rec))
    if cls != "ok":
        keep = os.path.join(os.path.abspath(base.out), "findings", str(index))
        shutil.rmtree(keep, ignore_errors=True)
        shutil.rmtree(os.path.join(case, "out"), ignore_errors=True)
        shutil.move(case, keep)
        quoted = " ".join(shlex.quote(a.decode()) if a.isascii() and a.decode().isprintable()
                          else "$'" + "".join("\\x%02x" % b for b in a) + "'"
                          for a in cmd).replace(case, keep)
        with open(os.path.join(keep, "cmd.sh"), "w") as f:
            f.write("#!/bin/bash\n# %s\ncd %s\n%s\n" % (json.dumps(rec["mutations"]),
                                                       shlex.quote(os.getcwd()), quoted))
        rec["reproducer"] = os.path.join(keep, "cmd.sh")
    else:
        shutil.rmtree(case, ignore_errors=True)
    return rec

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default="bin/autonomsim")
    ap.add_argument("--scenarios", default="scenarios")
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--count", type=int, default=100)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=60.0, help="seconds per run")
    ap.add_argument("--duration", default="1", help="duration_s set for each run")
    ap.add_argument("--nice", type=int, default=10)
    ap.add_argument("--only", type=int, help="run only mutant N")
    base = ap.parse_args()
    read = lambda p: open(os.path.join(base.scenarios, p), "rb").read()
    files = {"scenarios": {n: read(n) for n in sorted(os.listdir(base.scenarios))
                           if n.endswith(".yaml")},
             "track": read("tracks/lab.yaml"), "platform": read("platforms/zcu104.yaml")}
    indices = [base.only] if base.only is not None else range(base.count)
    t0, results = time.monotonic(), []
    with concurrent.futures.ThreadPoolExecutor(base.jobs) as pool:
        for n, rec in enumerate(pool.map(lambda i: run_one(base, files, i), indices), 1):
            results.append(rec)
            if rec["cls"] != "ok" or n % 100 == 0:
                print(f"[{n}/{len(indices)} {time.monotonic() - t0:.0f}s] #{rec['index']} "
                      f"rc={rec['rc']} {rec['cls']} {'+'.join(m['kind'] for m in rec['mutations'])}",
                      flush=True)
    wall = time.monotonic() - t0
    with open(os.path.join(base.out, "results.jsonl"), "w") as f:
        for rec in results: f.write(json.dumps(rec, ensure_ascii=False) + "\n")
    per_kind = collections.defaultdict(collections.Counter)
    for rec in results:
        for m in rec["mutations"]: per_kind[m["kind"]][str(rec["rc"])] += 1
    groups = collections.defaultdict(list)
    for rec in results:
        if rec["cls"] != "ok": groups[rec["signature"]].append(rec)
    accepted = collections.Counter(
        (m["target"], re.sub(r"\[\d+\]", "[i]", str(m["path"])), m["value"])
        for rec in results if rec["rc"] in (0, 1) for m in rec["mutations"]
        if m["kind"] in ("extreme_scalar", "set_value") and m["value"] and
        m["value"].encode() in NONSENSE and NUMBER.match(m["old"] or ""))
    summary = {"seed": base.seed, "count": len(results), "wall_s": round(wall, 1),
               "per_exit_code": collections.Counter(str(r["rc"]) for r in results),
               "per_class": collections.Counter(r["cls"] for r in results),
               "per_kind": per_kind,
               "findings": [{"signature": s, "count": len(rs), "indices": [r["index"] for r in rs],
                             "example": {k: rs[0].get(k) for k in ("reproducer", "mutations", "rc",
                                                                   "stderr")}}
                            for s, rs in sorted(groups.items(), key=lambda g: -len(g[1]))],
               "accepted_extremes": [{"target": t, "path": p, "value": v, "count": c}
                                     for (t, p, v), c in sorted(accepted.items())]}
    with open(os.path.join(base.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=1, ensure_ascii=False)
    md = [f"# autonomsim mutation fuzz: seed {base.seed}, {len(results)} mutants, {wall:.0f} s",
          "", "exit codes: " + json.dumps(summary["per_exit_code"]),
          "classes: " + json.dumps(summary["per_class"]), "", "| kind | runs per exit code |",
          "|---|---|"] + [f"| {k} | {dict(v)} |" for k, v in sorted(per_kind.items())]
    md += ["", f"## Findings ({sum(len(g) for g in groups.values())} in {len(groups)} groups)"]
    for g in summary["findings"]:
        md += ["", f"### {g['signature']} ({g['count']}x: {g['indices'][:10]})",
               f"- mutations: `{json.dumps(g['example']['mutations'], ensure_ascii=False)}`",
               f"- reproduce: `bash {g['example']['reproducer']}`", "```",
               g["example"]["stderr"].strip()[-800:], "```"]
    md += ["", "## Extreme values accepted (exit 0/1)", ""]
    md += [f"- {a['target']} `{a['path']}` = `{a['value']}` ({a['count']}x)"
           for a in summary["accepted_extremes"]]
    with open(os.path.join(base.out, "summary.md"), "w") as f: f.write("\n".join(md) + "\n")
    print("\n".join(md[:4]))
    return 0

if __name__ == "__main__":
    sys.exit(main())
