#!/usr/bin/env python3
"""The README's recipes, run as written, and the numbers the README quotes checked against that run.

Reads the fenced `sh` blocks of README.md's section "What do you want to do?", joins continued
lines, and runs every command with bash from a scratch folder that looks like the repository's top
folder (`build/` and `examples/` are links to the real ones, `out/` is fresh), so each command runs
verbatim. Commands listed in NOT_IN_CI are not run here, each for the reason given (they are
printed); every other command must exit 0. The lookup recipe reads the main job's 4 mm map
`out/seed001/map.h5`: it is made first exactly as scripts/main-job's step 4 makes it (about a minute).
Then the numbers the README quotes for the fit and lookup recipes, and the main job map's statement of
its total error, are parsed from the README's prose and compared with what that run printed, to the
digits quoted.

Usage: test_readme_recipes.py SOURCE_DIR BUILD_DIR
"""
import os
import re
import subprocess
import sys
import tempfile

# Commands of the recipes that CI does not run, matched by a fragment of the command, with why.
NOT_IN_CI = {
    "pvdfkit design": "two FEM maps at 4 mm: tens of minutes (measured in the README's own paragraph)",
    "cmake --install": "installs into $HOME; the deploy build is tested by ctest deploy_example",
    "cmake -S examples/deploy": "the deploy build is tested by ctest deploy_example",
    "build-deploy/locate_flat": "needs the deploy build and the exported map above",
}


def recipe_commands(readme_text):
    start = readme_text.index("## What do you want to do?")
    end = readme_text.index("\n## ", start + 1)
    section = readme_text[start:end]
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", section, re.S):
        joined = re.sub(r"\\\n\s*", " ", block)
        commands += [line.strip() for line in joined.splitlines() if line.strip() and not line.strip().startswith("#")]
    return section, commands


def quoted(section, pattern, label):
    m = re.search(pattern, section)
    if not m:
        raise SystemExit(f"README: the quoted {label} was not found (pattern {pattern!r}); update this test with the README")
    return m.group(1)


def agrees(quoted_text, value):
    """True when `value` rounds to the quoted number at the digits the README shows."""
    text = quoted_text.replace("−", "-")
    decimals = len(text.split(".")[1]) if "." in text else 0
    return abs(float(text) - value) <= 0.5 * 10 ** (-decimals) * (1 + 1e-9)


def main():
    source, build = sys.argv[1], sys.argv[2]
    readme = open(os.path.join(source, "README.md"), encoding="utf-8").read()
    section, commands = recipe_commands(readme)
    assert len(commands) >= 8, f"expected the README's recipes, found {len(commands)} commands"
    failures = []
    outputs = {}
    with tempfile.TemporaryDirectory(prefix="pvdf_readme_") as top:
        os.symlink(os.path.abspath(build), os.path.join(top, "build"))
        os.symlink(os.path.abspath(os.path.join(source, "examples")), os.path.join(top, "examples"))
        os.mkdir(os.path.join(top, "out"))
        # The main job's step 4 (scripts/main-job): the 4 mm seed-001 map the lookup recipe reads.
        main_job_map = ("examples/mapping/seed001-reproduction.sh out/seed001 --spacing-m 0.004 "
                        "--region -0.024,0.024,-0.024,0.024 --pvdfkit build/app/pvdfkit")
        print(f"main job's map: {main_job_map}", flush=True)
        r = subprocess.run(["bash", "-c", main_job_map], cwd=top, capture_output=True, text=True, timeout=900)
        if r.returncode != 0:
            failures.append(f"exit {r.returncode}: {main_job_map}\n{r.stderr[-2000:]}")
        main_job_output = r.stdout
        for cmd in commands:
            reason = next((why for frag, why in NOT_IN_CI.items() if frag in cmd), None)
            if reason:
                print(f"not run in CI: {cmd}\n    because {reason}")
                continue
            print(f"run: {cmd}", flush=True)
            r = subprocess.run(["bash", "-c", cmd], cwd=top, capture_output=True, text=True, timeout=900,
                               env=dict(os.environ, PVDFKIT=os.path.join(os.path.abspath(build), "app", "pvdfkit")))
            outputs[cmd] = r.stdout + r.stderr
            if r.returncode != 0:
                failures.append(f"exit {r.returncode}: {cmd}\n{r.stderr[-2000:]}")
    # The fit recipe's quoted numbers against its run.
    fit_cmd = next(c for c in commands if " fit " in f" {c} " or "pvdfkit fit" in c)
    out = outputs.get(fit_cmd, "")
    if out:
        def printed(pattern, label):
            m = re.search(pattern, out)
            if not m:
                failures.append(f"the fit's output has no {label} (pattern {pattern!r})")
                return None
            return float(m.group(1))
        pairs = [
            (quoted(section, r"E_scale = ([0-9.]+) ±", "E_scale"), printed(r"\nE_scale\s+\S+\s+(\S+)", "E_scale value"), 1, "E_scale"),
            (quoted(section, r"E_scale = [0-9.]+ ± ([0-9.]+)", "E_scale sigma"), printed(r"\nE_scale\s+\S+\s+\S+\s+(\S+)", "E_scale sigma"), 1, "E_scale 1-sigma"),
            (quoted(section, r"d31 = ([0-9.]+) ±", "d31"), printed(r"\nd31_C_per_N\s+\S+\s+(\S+)", "d31 value"), 1e12, "d31 (pC/N)"),
            (quoted(section, r"d31 = [0-9.]+ ± ([0-9.]+) pC/N", "d31 sigma"), printed(r"\nd31_C_per_N\s+\S+\s+\S+\s+(\S+)", "d31 sigma"), 1e12, "d31 1-sigma (pC/N)"),
            (quoted(section, r"reduced χ² ([0-9.]+)", "reduced chi2"), printed(r"reduced chi2 ([0-9.]+)", "reduced chi2"), 1, "reduced chi2"),
            (quoted(section, r"from ([0-9.]+) mm to [0-9.]+ mm", "start deflection"), printed(r"deflection_m\s+\S+\s+\S+\s+(\S+)", "start deflection"), 1e3, "deflection at the start (mm)"),
            (quoted(section, r"from [0-9.]+ mm to ([0-9.]+) mm", "fitted deflection"), printed(r"deflection_m\s+\S+\s+\S+\s+\S+\s+(\S+)", "fitted deflection"), 1e3, "fitted deflection (mm)"),
            (quoted(section, r"\(([−-][0-9.]+) σ\)", "deflection residual"), printed(r"deflection_m(?:\s+\S+){4}\s+(\S+)", "deflection residual"), 1, "deflection residual (sigma)"),
        ]
        for text, value, scale, label in pairs:
            if value is None:
                continue
            ok = agrees(text, value * scale)
            print(f"README quotes {label} {text}; this run printed {value * scale:.6g}: {'agrees' if ok else 'DIFFERS'}")
            if not ok:
                failures.append(f"README quotes {label} = {text}, the run printed {value * scale:.6g}")
    # The main job's map statement of its total error (the lookup paragraph quotes it).
    statement = r"median ([0-9.]+) %, 90 % of the presses below ([0-9.]+) %, at most ([0-9.]+) %"
    quoted_statement = re.search(statement, section)
    printed_statement = re.search(statement, main_job_output)
    if not quoted_statement:
        failures.append(f"README: the main job map's statement was not found (pattern {statement!r}); update this test")
    elif not printed_statement:
        failures.append(f"the main job's map printed no statement of its total error (pattern {statement!r})")
    else:
        for label, text, value in zip(("median", "90th percentile", "largest"), quoted_statement.groups(),
                                      printed_statement.groups()):
            ok = agrees(text, float(value))
            print(f"README quotes the map's {label} total error {text} %; the map printed {value} %: "
                  f"{'agrees' if ok else 'DIFFERS'}")
            if not ok:
                failures.append(f"README quotes the main job map's {label} total error {text} %, the map printed {value} %")
    # The lookup recipe's quoted answers against its run (JSON on stdout).
    import json
    locate_cmds = [c for c in commands if "pvdfkit locate out/seed001/map.h5" in c]
    unknown = next((c for c in locate_cmds if "--force-N" not in c), None)
    known = next((c for c in locate_cmds if "--force-N" in c), None)
    checks = []
    if unknown and known:
        q = r"With the force unknown it answers \(([−-]?[0-9.]+), ([−-]?[0-9.]+)\) mm at ([0-9.]+) N with σ ([0-9.]+) / ([0-9.]+) mm"
        m = re.search(q, section)
        if not m:
            failures.append(f"README: the force-unknown answer was not found (pattern {q!r}); update this test with the README")
        else:
            checks.append((unknown, m.groups(), ["x_m", "y_m", "force_N", "sigma_x_m", "sigma_y_m"], [1e3, 1e3, 1, 1e3, 1e3]))
        q = r"With the force known it answers \(([−-]?[0-9.]+), ([−-]?[0-9.]+)\) mm with σ ([0-9.]+) / ([0-9.]+) mm"
        m = re.search(q, section)
        if not m:
            failures.append(f"README: the force-known answer was not found (pattern {q!r}); update this test with the README")
        else:
            checks.append((known, m.groups(), ["x_m", "y_m", "sigma_x_m", "sigma_y_m"], [1e3, 1e3, 1e3, 1e3]))
    else:
        failures.append("README: the two locate commands of the lookup recipe were not found")
    for cmd, texts, keys, scales in checks:
        out = outputs.get(cmd, "")
        try:
            answer = json.loads(out[out.index("{"):out.rindex("}") + 1])
        except ValueError:
            failures.append(f"no JSON answer from: {cmd}")
            continue
        for text, key, scale in zip(texts, keys, scales):
            value = answer.get(key)
            ok = isinstance(value, (int, float)) and agrees(text, value * scale)
            print(f"README quotes {key} {text}; `{cmd[-40:]}` printed {value}: {'agrees' if ok else 'DIFFERS'}")
            if not ok:
                failures.append(f"README quotes {key} = {text} for `{cmd}`, the run printed {value}")
    if failures:
        print("\nFAILED:\n" + "\n".join(failures))
        return 1
    print(f"\nall {len(outputs)} recipe commands run in CI exited 0; the fit's and the lookup's quoted numbers agree")
    return 0


if __name__ == "__main__":
    sys.exit(main())
