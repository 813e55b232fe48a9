#!/usr/bin/python3
"""Whether two run files hold the same records, bit for bit.

  same_records.py A.h5 B.h5 [GROUP ...]

Compares the datasets under each group (default /records, /crossings, /trajectories):
the same names, shapes, types and bytes (NaN equal to NaN of the same bits). A group
absent from both files is skipped; present in one only, it differs. Prints one line per
difference and exits 1 if any, 0 if none. (h5diff reports datasets of different shapes
as "not comparable" and exits 0.) Needs h5py and numpy.
"""
import sys

import h5py


def datasets(group, prefix=""):
    out = {}
    for name, item in group.items():
        path = f"{prefix}/{name}"
        if isinstance(item, h5py.Group):
            out.update(datasets(item, path))
        else:
            out[path] = item
    return out


def main(argv):
    if len(argv) < 3:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    groups = argv[3:] or ["/records", "/crossings", "/trajectories"]
    differ = []
    with h5py.File(argv[1], "r") as a, h5py.File(argv[2], "r") as b:
        for g in groups:
            if g not in a and g not in b:
                continue
            if (g in a) != (g in b):
                differ.append(f"{g}: present in one file only")
                continue
            da, db = datasets(a[g], g), datasets(b[g], g)
            for name in sorted(set(da) | set(db)):
                if name not in da or name not in db:
                    differ.append(f"{name}: present in one file only")
                    continue
                x, y = da[name][()], db[name][()]
                if getattr(x, "shape", None) != getattr(y, "shape", None) or getattr(x, "dtype", None) != getattr(y, "dtype", None):
                    differ.append(f"{name}: shape or type differ")
                elif (x.tobytes() if hasattr(x, "tobytes") else bytes(x)) != (y.tobytes() if hasattr(y, "tobytes") else bytes(y)):
                    differ.append(f"{name}: values differ")
    for line in differ:
        print(f"{argv[2]}: {line}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
