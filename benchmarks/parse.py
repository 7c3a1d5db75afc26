"""Parse throughput (lines/s) per dialect on 10^6-line programs (target: >= 1.5 x 10^5 lines/s for RAPID, KRL and G-code, issue 12; >= 10^5 for the later languages, issues 29 and 30).

Run: .venv/bin/python benchmarks/parse.py [--lines 1000000]
Writes one program per dialect to a temporary folder (moves with literal targets, the bulk
of real CAM output; a KRL .src whose points live in its .dat), then times parse and the
unchanged emit (round trip), and reports the peak memory of each run in a fresh process.
Wall time and the parse's CPU time are both printed, with the load average at the start; the
target is judged on lines per CPU second (on a shared, loaded machine the wall time measures
the other jobs; on an idle one the two agree).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _write(path: Path, head: str, lines, tail: str) -> Path:
    """``path`` with ``head``, the generated ``lines`` (an iterable of whole lines) and ``tail``."""
    with open(path, "w", encoding="latin-1") as fh:
        fh.write(head)
        fh.writelines(lines)
        fh.write(tail)
    return path


def _x(i: int) -> float:
    return 800 + (i % 400) * 0.5


def _y(i: int) -> float:
    return -200 + (i // 400) % 400


def _z(i: int) -> float:
    return 300 + (i % 7) * 0.125



def make_fanuc(folder: Path, n: int) -> Path:
    """A Fanuc TP listing of about ``n`` lines: L motions in /MN, their positions in /POS (7 lines a target)."""
    count = max((n - 8) // 7, 1)
    motions = "".join(f"{i + 1:4d}:L P[{i + 1}] 100mm/sec CNT50    ;\n" for i in range(count))
    positions = (f"P[{i + 1}]{{\n   GP1:\n\tUF : 0, UT : 0,\t\tCONFIG : 'N U T, 0, 0, 0',\n"
                 f"\tX = {_x(i):9.3f}  mm,\tY = {_y(i):9.3f}  mm,\tZ = {_z(i):9.3f}  mm,\n"
                 "\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg\n};\n" for i in range(count))
    return _write(folder / "big.ls", "/PROG  BIG\n/ATTR\nOWNER\t\t= MNEDITOR;\nDEFAULT_GROUP\t= 1,*,*,*,*;\n/MN\n" + motions + "/POS\n",
                  positions, "/END\n")


def make_programs(folder: Path, n: int) -> dict[str, Path]:
    out = {}
    out["rapid"] = _write(folder / "big.mod", "MODULE Big\n  PROC main()\n",
                          (f"    MoveL [[{_x(i):.3f},{_y(i):.3f},{_z(i):.3f}],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tool0;\n"
                           for i in range(n - 5)), "  ENDPROC\nENDMODULE\n")
    out["krl"] = _write(folder / "big_inline.src", "DEF big_inline( )\n$APO.CDIS = 0.5\n",
                        (f"LIN {{X {_x(i):.3f}, Y {_y(i):.3f}, Z {_z(i):.3f}, A 0, B 180, C 0}} C_DIS\n" for i in range(n - 3)), "END\n")
    half = n // 2
    _write(folder / "big_dat.dat", "DEFDAT big_dat\n",
           (f"DECL E6POS XP{i}={{X {_x(i):.3f},Y {_y(i):.3f},Z {_z(i):.3f},A 0.0,B 180.0,C 0.0,S 2,T 10}}\n" for i in range(half - 2)), "ENDDAT\n")
    out["krl (.src + .dat)"] = _write(folder / "big_dat.src", "DEF big_dat( )\n", (f"LIN XP{i} C_DIS\n" for i in range(half - 2)), "END\n")
    # A CAM point list: a FRAME array in the .dat, stepped through by a FOR to n (issue 28)
    count = max(half - 3, 1)
    _write(folder / "frame_array.dat", f"DEFDAT frame_array PUBLIC\nDECL GLOBAL FRAME gfPoint[{count}]\n",
           (f"gfPoint[{i}]={{X {_x(i):.3f},Y {_y(i):.3f},Z {_z(i):.3f},A 0.0,B 180.0,C 0.0}}\n" for i in range(1, count + 1)), "ENDDAT\n")
    out["krl FRAME[] + FOR"] = _write(folder / "frame_array.src", f"DEF frame_array( )\nDECL INT i\nDECL INT n\nn = {count}\nFOR i = 1 TO n\n"
                                      "  LIN gfPoint[i] C_DIS\nENDFOR\nEND\n", (), "")
    out["gcode"] = _write(folder / "big.ngc", "G21 G90 G17\nG0 X0 Y0 Z5\nF1500\n",
                          (f"G1 X{(i % 400) * 0.5:.3f} Y{(i // 400) % 400:.3f} Z{-1 - (i % 7) * 0.125:.3f}\n" for i in range(n - 4)), "M2\n")
    out["urscript"] = make_urscript(folder, n)
    out["fanuc"] = make_fanuc(folder, n)
    out["sinumerik"] = make_sinumerik(folder, n)
    out["inform"] = make_inform(folder, n)
    out["val3 (.pgx + .dtx)"] = make_val3(folder, n)
    out["heidenhain"] = make_heidenhain(folder, n)
    return out


def make_sinumerik(folder: Path, n: int) -> Path:
    """A SINUMERIK 840D five-axis CAM program: a header with a settable frame, R parameters and
    programmable frames (the reader's slow path), then numbered TRAORI blocks."""
    path = folder / "BIG.MPF"
    header = ["; postproc benchmark", "N10 G54 G17 G71 G90 G94", "N20 R1=12.5 R2=-7", "N30 TRANS X=R1 Y=R2", "N40 AROT Z30", "N50 TRAORI",
              "N60 G0 X0 Y0 Z50 A0 C0", "N70 G1 F1500"]
    with open(path, "w", encoding="latin-1") as fh:
        fh.write("\n".join(header) + "\n")
        for i in range(n - len(header) - 2):
            fh.write(f"N{80 + i} X{(i % 400) * 0.5:.3f} Y{(i // 400) % 400:.3f} Z{-1 - (i % 7) * 0.125:.3f} A{(i % 90) * 0.25:.3f} C{(i % 360) * 0.5:.3f}\n")
        fh.write("TRAFOOF\nM30\n")
    return path


def make_urscript(folder: Path, n: int) -> Path:
    """A URScript program: set_tcp, one movej to joints, then movel to literal poses (m, rad)."""
    head = "def big():\n  set_tcp(p[0, 0, 0.2, 0, 0, 0])\n  movej([0, -1.5708, 1.5708, -1.5708, -1.5708, 0], a=1.4, v=1.05)\n"
    return _write(folder / "big.script", head, (f"  movel(p[{_x(i) / 1000:.6f}, {_y(i) / 1000:.6f}, {_z(i) / 1000:.6f}, 0, 3.1416, 0], a=1.2, v=0.25, r=0.0005)\n"
                                                for i in range(n - 4)), "end\n")


def make_inform(folder: Path, n: int) -> Path:
    """A Yaskawa INFORM job: half its lines ///RECTAN positions, half the MOVL lines to them."""
    count = max((n - 14) // 2, 1)
    head = f"/JOB\r\n//NAME BIG\r\n//POS\r\n///NPOS {count},0,0,0,0,0\r\n///TOOL 0\r\n///POSTYPE ROBOT\r\n///RECTAN\r\n///RCONF 1,0,0,0,0,0,0,0\r\n"
    positions = "".join(f"C{i:05d}={_x(i):.3f},{_y(i):.3f},{_z(i):.3f},180.0000,0.0000,0.0000\r\n" for i in range(count))
    return _write(folder / "BIG.JBI", head + positions + "//INST\r\n///DATE 2024/01/01 00:00\r\n///ATTR SC,RW\r\n///GROUP1 RB1\r\nNOP\r\n",
                  (f"MOVL C{i:05d} V=100.0 PL=0\r\n" for i in range(count)), "END\r\n")


def make_val3(folder: Path, n: int) -> Path:
    """A Stäubli VAL3 application: n/2 movel lines in start.pgx, their points in the .dtx."""
    app = folder / "val3"
    app.mkdir()
    count = max(n // 2 - 8, 1)
    with open(app / "start.pgx", "w", encoding="latin-1") as fp, open(app / "big.dtx", "w", encoding="latin-1") as fd:
        fp.write('<?xml version="1.0" encoding="utf-8"?>\n<Programs xmlns="http://www.staubli.com/robotics/VAL3/Program/2">\n'
                 '  <Program name="start">\n    <Code><![CDATA[begin\n')
        fd.write('<?xml version="1.0" encoding="utf-8"?>\n<Database xmlns="http://www.staubli.com/robotics/VAL3/Data/2">\n  <Datas>\n'
                 '    <Data name="tTool" type="tool" size="1">\n      <Value key="0" z="200" fatherId="flange[0]" />\n    </Data>\n'
                 '    <Data name="mCut" type="mdesc" size="1">\n      <Value key="0" tmax="100" blend="Cartesian" leave="0.5" reach="0.5" />\n    </Data>\n'
                 f'    <Data name="pCut" type="pointRx" size="{count}">\n')
        for i in range(count):
            fp.write(f"  movel(pCut[{i}], tTool, mCut)\n")
            fd.write(f'      <Value key="{i}" x="{800 + (i % 400) * 0.5:.3f}" y="{-200 + (i // 400) % 400:.3f}" z="{300 + (i % 7) * 0.125:.3f}" rx="180" ry="0" rz="0" fatherId="world[0]" />\n')
        fp.write("end\n]]></Code>\n  </Program>\n</Programs>\n")
        fd.write("    </Data>\n  </Datas>\n</Database>\n")
    return app / "start.pgx"


def make_heidenhain(folder: Path, n: int) -> Path:
    """A five-axis Klartext program: numbered L blocks with tip and rotary positions under M128."""
    return _write(folder / "big.h", "0 BEGIN PGM BIG MM\n1 TOOL CALL 1 Z S12000\n2 M128\n",
                  (f"{i + 3} L  X{(i % 400) * 0.5:+.3f}  Y{(i // 400) % 400:+.3f}  Z{-1 - (i % 7) * 0.125:+.3f}  A{-(i % 30) * 0.5:+.3f}  C{(i % 360):+.3f} F1500\n"
                   for i in range(n - 5)), f"{n - 2} M129\n{n - 1} END PGM BIG MM\n")


def measure(path: str) -> None:
    """Child process: parse and round-trip one program, print JSON."""
    from postproc.programs import emit_texts, parse_program

    t0, c0 = time.perf_counter(), time.process_time()
    tp = parse_program(path)
    t_parse, cpu_parse = time.perf_counter() - t0, time.process_time() - c0
    lines = sum(doc.text.count("\n") for doc in tp.sources)  # every file the program was read from (KRL's .dat, VAL3's .dtx)
    t0 = time.perf_counter()
    texts = emit_texts(tp, tp)
    t_emit = time.perf_counter() - t0
    assert all(t.encode("latin-1") == d.encode() for t, d in zip(texts, tp.sources))
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(json.dumps({"lines": lines, "targets": len(tp), "parse_s": t_parse, "parse_cpu_s": cpu_parse, "emit_s": t_emit, "peak_mb": peak_mb}))


# Lines per CPU second: issue 12's for the first languages, issues 29 and 30's for the others.
TARGET = {"rapid": 1.5e5, "krl": 1.5e5, "krl (.src + .dat)": 1.5e5, "krl FRAME[] + FOR": 1.5e5, "gcode": 1.5e5}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=1_000_000)
    parser.add_argument("--measure", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.measure:
        measure(args.measure)
        return
    with tempfile.TemporaryDirectory() as tmp:
        programs = make_programs(Path(tmp), args.lines)
        os.sync()  # the programs' write-back would otherwise compete with the first measurement
        print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())} (1, 5, 15 min)")
        print(f"{'dialect':<20}{'lines':>10}{'targets':>10}{'parse s':>9}{'lines/s':>12}{'CPU s':>8}{'lines/CPU s':>13}{'round trip s':>14}{'peak MB':>9}   target, lines per CPU s")
        for name, path in programs.items():
            proc = subprocess.run([sys.executable, __file__, "--measure", str(path)], capture_output=True, text=True, env=os.environ)
            if proc.returncode:
                print(f"{name:<20} failed: {proc.stderr[-500:]}")
                continue
            r = json.loads(proc.stdout)
            rate = r["lines"] / r["parse_s"]
            cpu_rate = r["lines"] / r["parse_cpu_s"]
            print(f"{name:<20}{r['lines']:>10,}{r['targets']:>10,}{r['parse_s']:>9.2f}{rate:>12,.0f}{r['parse_cpu_s']:>8.2f}{cpu_rate:>13,.0f}"
                  f"{r['emit_s']:>14.2f}{r['peak_mb']:>9.0f}   {TARGET.get(name, 1e5):.1e} {'met' if cpu_rate >= TARGET.get(name, 1e5) else 'MISSED'}")


if __name__ == "__main__":
    main()
