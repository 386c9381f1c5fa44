#!/usr/bin/env python3
"""Agreement check of the peer comparison: `agree.py CPP_VALUES RUST_VALUES [TOL]`.

Both harnesses' `--values` print one line per call, `name<TAB>k<TAB>v...`, for the same inputs
and in omnikin's units; the Rust side prints each call a second time through `omnikin::Robot`
(`robot_<name>`), compared with the same WPILib line (wheel rates rad/s, directions as cos and sin, poses x, y, cos, sin).
Every value must agree to TOL (default 1e-9) relative to max(1, |WPILib value|); prints the
largest difference per benchmark and exits 1 on any disagreement or missing line.
"""
import sys


def load(path):
    out = {}
    for n, line in enumerate(open(path), 1):
        f = line.rstrip("\n").split("\t")
        if len(f) < 3:
            sys.exit(f"{path}:{n}: expected name, k and values, got {line!r}")
        out[(f[0], int(f[1]))] = [float(x) for x in f[2:]]
    return out


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    cpp, rust = load(sys.argv[1]), load(sys.argv[2])
    # The Rust side prints every call twice: through the concrete model (`mecanum_inverse`)
    # and through `omnikin::Robot` (`robot_mecanum_inverse`); both are held to WPILib's row.
    cpp.update({("robot_" + name, k): v for (name, k), v in list(cpp.items())})
    tol = float(sys.argv[3]) if len(sys.argv) == 4 else 1e-9
    ok = True
    if cpp.keys() != rust.keys():
        missing = sorted(set(cpp) ^ set(rust))[:5]
        print(f"the two sides printed different calls, e.g. {missing}")
        ok = False
    worst = {}
    for key in sorted(set(cpp) & set(rust)):
        a, b = rust[key], cpp[key]
        if len(a) != len(b):
            print(f"{key}: {len(a)} values (omnikin) vs {len(b)} (WPILib)")
            ok = False
            continue
        for i, (x, y) in enumerate(zip(a, b)):
            err = abs(x - y) / max(1.0, abs(y))
            name = key[0]
            if err > worst.get(name, (0.0,))[0]:
                worst[name] = (err, key[1], i, x, y)
            if not err <= tol:
                ok = False
    for name in sorted({k[0] for k in cpp}):
        n = sum(1 for k in cpp if k[0] == name)
        e = worst.get(name, (0.0, 0, 0, 0.0, 0.0))
        flag = "ok" if e[0] <= tol else "DISAGREE"
        print(f"  {name:<24} {n:4} calls  max rel. diff {e[0]:.2e}  {flag}"
              + (f" (call {e[1]}, value {e[2]}: omnikin {e[3]!r}, WPILib {e[4]!r})" if e[0] > tol else ""))
    if not ok:
        sys.exit(f"omnikin and WPILib disagree beyond {tol}")
    print(f"agreement: every value within {tol} (relative to max(1, |WPILib|))")


main()
