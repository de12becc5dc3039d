"""Compare two baseline directories with scale-aware tolerances: arrays relative to their largest
magnitude, scalars relative to themselves; residual norms (round-off floor) reported apart;
Floquet multipliers compared as sets (sorted by modulus, then angle)."""
import json, sys, os, csv, math
a, b = sys.argv[1], sys.argv[2]
worst = {}; notes = []
ROUNDOFF = {"residual_norm", "period_change", "period_change_history"}
def upd(name, key, d):
    w = worst.setdefault(name, {})
    w[key] = max(w.get(key, 0.0), d)
def isnum(v): return isinstance(v, (int, float)) and not isinstance(v, bool)
def cmp(x, y, path, name, key=""):
    if isinstance(x, dict):
        if set(x) != set(y): notes.append(f"{name}{path}: keys differ"); return
        for k in x:
            xv, yv = x[k], y[k]
            if k == "multipliers":
                xv = sorted(xv, key=lambda m: (round(math.hypot(*m), 9), math.atan2(m[1], m[0])))
                yv = sorted(yv, key=lambda m: (round(math.hypot(*m), 9), math.atan2(m[1], m[0])))
            cmp(xv, yv, path + "." + k, name, k)
    elif isinstance(x, list):
        if len(x) != len(y): notes.append(f"{name}{path}: length {len(x)} vs {len(y)}"); return
        if x and all(isnum(v) for v in x) and all(isnum(v) for v in y):
            scale = max(max(abs(v) for v in x), 1e-300)
            d = max(abs(p - q) for p, q in zip(x, y)) / scale
            upd(name, "roundoff-fields" if key in ROUNDOFF else key or "array", d); return
        for i, (p, q) in enumerate(zip(x, y)): cmp(p, q, f"{path}[{i}]", name, key)
    elif isnum(x) and isnum(y):
        d = abs(x - y) / max(abs(x), abs(y), 1e-300) if x != y else 0.0
        upd(name, "roundoff-fields" if key in ROUNDOFF else "scalars", d)
    elif x != y:
        notes.append(f"{name}{path}: {x!r} vs {y!r}")
def num(s):
    try: return float(s)
    except: return s
for f in sorted(os.listdir(a)):
    pa, pb = os.path.join(a, f), os.path.join(b, f)
    if f.endswith(".json"):
        ta, tb = open(pa).read().strip(), open(pb).read().strip()
        try: ja, jb = json.loads(ta), json.loads(tb)
        except Exception:
            if ta != tb: notes.append(f"{f}: text differs")
            continue
        cmp(ja, jb, "", f)
    elif f.endswith(".csv"):
        # '#' lines are comments (the status line that ends a streamed CSV): not numbers
        ra = [r for r in csv.reader(open(pa)) if not (r and r[0].startswith("#"))]
        rb = [r for r in csv.reader(open(pb)) if not (r and r[0].startswith("#"))]
        if len(ra) != len(rb): notes.append(f"{f}: rows {len(ra)} vs {len(rb)}"); continue
        hdr = ra[0]
        for j, h in enumerate(hdr):
            col_a = [num(r[j]) for r in ra[1:] if j < len(r)]; col_b = [num(r[j]) for r in rb[1:] if j < len(r)]
            if col_a and all(isinstance(v, float) for v in col_a + col_b):
                scale = max(max(abs(v) for v in col_a), 1e-300)
                d = max(abs(p - q) for p, q in zip(col_a, col_b)) / scale
                upd(f, "roundoff-fields" if h == "residual_norm" else h, d)
            elif col_a != col_b: notes.append(f"{f}: column {h} differs")
    elif f == "exit.txt" and open(pa).read() != open(pb).read(): notes.append("exit codes differ")
for n in notes: print(n)
for f, w in sorted(worst.items()):
    main = {k: v for k, v in w.items() if k != "roundoff-fields"}
    m = max(main.values()) if main else 0.0
    worstkey = max(main, key=main.get) if main else "-"
    print(f"{f}: worst {m:.1e} ({worstkey}); residual-type fields {w.get('roundoff-fields', 0):.1e}")
