"""The bench/dda scripts' way of running a tool: its command line and output appended to a
log, and the script ended with a one-line error naming the tool if it fails."""
import os
import subprocess
import sys


def run(cmd, log):
    with open(log, "a") as f:
        f.write(" ".join(cmd) + "\n")
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        script = os.path.basename(sys.argv[0])
        sys.exit(f"{script}: {os.path.basename(cmd[0])} failed (exit {r.returncode}); see {log}")
