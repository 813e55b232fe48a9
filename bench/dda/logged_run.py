"""The bench/dda scripts' way of running a tool: its command line and output appended to a
log, and the script ended with a one-line error naming the tool if it fails or cannot
be started. bench/field uses it too."""
import os
import subprocess
import sys


def run(cmd, log):
    script = os.path.basename(sys.argv[0])
    with open(log, "a") as f:
        f.write(" ".join(cmd) + "\n")
        try:
            r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
        except OSError as e:  # a tool not built, or not executable
            sys.exit(f"{script}: {cmd[0]}: {e.strerror}")
    if r.returncode != 0:
        sys.exit(f"{script}: {os.path.basename(cmd[0])} failed (exit {r.returncode}); see {log}")
