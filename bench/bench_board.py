"""Board-console figures, against ``stepperdemo device --pty --console`` at real speed.

    python bench/bench_board.py [--speed F]

1. The console device's CPU per wall second: idle (no host), and while a host runs
   the README move (``M1 A1000 V100 R3200 W``) - it should sleep, not poll.
2. Wall time of ``stepperdemo --board PTY -c "M1 A1000 V100 R3200 W"`` (the move
   itself takes 3.58 s on the board) and the overhead around it: the start-up
   wait, the pacing of the commands, the quiet time that ends the run.
3. Pacing: commands per second through the pacer for a line of 40 short commands.
4. The twin: wall time to run ``sequences/examples`` on the simulated board on
   virtual time (what ``run --board`` adds per scenario).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def cpu_s(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def cli(*args: str) -> tuple[float, subprocess.CompletedProcess]:
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-m", "stepperdemo", *args], cwd=ROOT,
                         capture_output=True, check=False)
    return time.perf_counter() - t0, res


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--speed", type=float, default=1.0)
    args = ap.parse_args()
    link = os.path.join(tempfile.mkdtemp(), "board")
    dev = subprocess.Popen([sys.executable, "-m", "stepperdemo", "device", "--pty",
                            "--console", "--speed", str(args.speed), "--link", link],
                           cwd=ROOT, stdout=subprocess.PIPE, text=True)
    dev.stdout.readline()
    try:
        c0, w0 = cpu_s(dev.pid), time.perf_counter()
        time.sleep(2.0)
        idle = (cpu_s(dev.pid) - c0) / (time.perf_counter() - w0)
        c0, w0 = cpu_s(dev.pid), time.perf_counter()
        wall, res = cli("--board", link, "-c", "M1 A1000 V100 R3200 W")
        moving = (cpu_s(dev.pid) - c0) / (time.perf_counter() - w0)
        assert res.returncode == 0 and b">> M1: @3200 " in res.stdout, res.stderr
        line = " ".join(f"M{1 + i % 2}" for i in range(40))
        pace_wall, res = cli("--board", link, "-c", line, "--quiet-ms", "100")
        assert res.returncode == 0 and res.stdout.count(b"Select stepper") == 40
    finally:
        dev.terminate()
        dev.wait()
    from stepperdemo.front.board_link import SimBoardLink
    from stepperdemo.front.board_session import BoardSession
    from stepperdemo.scenarios.board_runner import run_side
    from stepperdemo.scenarios.scenario import collect, load

    t0 = time.perf_counter()
    files = collect(["sequences/examples"])
    for f in files:
        run_side(BoardSession(SimBoardLink()), load(f), reset=False)
    twin = (time.perf_counter() - t0) / len(files)
    print(f"device CPU idle (no host):      {idle * 100:.1f} % of one core")
    print(f"device CPU during the -c run:   {moving * 100:.1f} % of one core")
    print(f"-c README move wall time:       {wall:.2f} s (the move: 3.58 s / speed "
          f"{args.speed:g}; the rest: start, pacing, quiet end)")
    print(f"pacing, 40 commands:            {pace_wall:.2f} s wall "
          f"(including start-up and the 0.1 s quiet end)")
    print(f"twin on virtual time:           {twin:.2f} s per example scenario")


if __name__ == "__main__":
    main()
