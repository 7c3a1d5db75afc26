"""Which G codes a program may hold: a G word the controller does not know is refused as the
controller refuses it, and one it knows but postproc does not model is refused too, since
reading past either gives wrong positions (``G999 X40 Y10`` was read as a move to (40, 10)).

LinuxCNC's G codes are the numbers its interpreter takes: rs274 (Debian linuxcnc-uspace)
run here on every ``G0`` ... ``G99.9`` block answered "Unknown g code used" (or "G-code
out of range" from G100 on) for all numbers except the ones in ``LINUXCNC``.
"""

from __future__ import annotations

LINUXCNC = frozenset({
    0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 5.1, 5.2, 5.3, 7.0, 8.0, 10.0, 17.0, 17.1, 18.0, 18.1, 19.0, 19.1, 20.0, 21.0,
    28.0, 28.1, 30.0, 30.1, 33.0, 33.1, 38.2, 38.3, 38.4, 38.5, 40.0, 41.0, 41.1, 42.0, 42.1, 43.0, 43.1, 43.2, 49.0,
    52.0, 53.0, 54.0, 55.0, 56.0, 57.0, 58.0, 59.0, 59.1, 59.2, 59.3, 61.0, 61.1, 64.0, 70.0, 71.0, 71.1, 71.2,
    72.0, 72.1, 72.2, 73.0, 74.0, 76.0, 80.0, 81.0, 82.0, 83.0, 84.0, 85.0, 86.0, 87.0, 88.0, 89.0, 90.0, 90.1,
    91.0, 91.1, 92.0, 92.1, 92.2, 92.3, 93.0, 94.0, 95.0, 96.0, 97.0, 98.0, 99.0,
})

# Codes LinuxCNC takes that postproc does not follow: each changes where the tool goes or what
# the axis words mean (LinuxCNC manual, G-code reference), so reading past it is wrong. Plain
# G70 / G71 are not among them: SINUMERIK, Heidenhain and most ISO controls read them as inch /
# metric (a program postproc writes for SINUMERIK has "G71"), LinuxCNC as lathe cycles; they
# are read as before (units on SINUMERIK programs).
NOT_MODELLED = {
    5.0: "G5 cubic spline", 5.1: "G5.1 quadratic spline", 5.2: "G5.2 NURBS block", 5.3: "G5.3 NURBS block end",
    7.0: "G7 lathe diameter mode (X words are diameters)",
    71.1: "G71.1 lathe roughing cycle", 71.2: "G71.2 lathe roughing cycle",
    72.0: "G72 lathe facing cycle", 72.1: "G72.1 lathe facing cycle", 72.2: "G72.2 lathe facing cycle",
    76.0: "G76 threading cycle",
}

# ISO / Fanuc codes outside LinuxCNC that the reader follows: tool centre point control
# (G43.4 / G43.5) and tilted working planes (G68.2; G68, G68.3, G68.4 flag what follows).
OTHER_READ = frozenset({43.4, 43.5, 68.0, 68.2, 68.3, 68.4, 69.0})


def refusal(code: float) -> str | None:
    """Why a block with G``code`` is refused (None: the reader follows it). Not for SINUMERIK
    programs, whose G groups are another set (siemens.py)."""
    name = f"G{code:g}"
    if code in NOT_MODELLED:
        remedy = "write X as radii under G8" if code == 7.0 else "expand it to G0/G1/G2/G3 blocks"
        return f"{NOT_MODELLED[code]}: postproc does not model it, and reading past it would give wrong positions ({remedy})"
    if code in LINUXCNC or code in OTHER_READ:
        return None
    rs274 = "G-code out of range" if code >= 100 else "Unknown g code used"
    return f"{name} is not a G code the controller knows (LinuxCNC's rs274: '{rs274}'); it is refused, not read as a move"


# M codes rs274 runs (the same probe, ``M0`` ... ``M199`` before a G1 block): every other
# integer answered "Unknown m code used" (from M200 on "M-code greater than 199"), a
# fractional one "Non integer value for integer". A machine's configuration can give the
# others a meaning (LinuxCNC manual, "Remap Extending G-code"; its interpreter's header
# rs274ngc_interp.hh: ``M_REMAPPABLE(m) ((m >= 0) && (m < 1000) && ...)``; M100-M199 run a user
# program of that name): LinuxCNC's own 5-axis demos switch kinematics with M428 / M429. So an integer M code up to M999 that is
# not built in is read with a note (it moves no axis here; the note names what rs274 says
# without such a configuration); a fractional one, or one from M1000 on, is refused.
LINUXCNC_M = frozenset({0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 19, 30, 48, 49, 50, 51, 52, 53, 60, 61, 62, 63, 64, 65, 66, 67,
                        68, 70, 71, 72, 73, 98, 99})
CONFIGURABLE_M = range(0, 1000)


# Letters rs274 refuses outright wherever they stand ("Bad character 'n' used": N only starts
# a block; U V W are refused by the reader for its own reason, the axis it cannot hold).
BAD_CHARACTER = frozenset("N")

# rs274: "E word with no G70, G76, M66, M67 or M68 to use it" (the probe: ``G1 X1 E1``). An
# extruder E word (3D printers) would otherwise be read past, the block's motion kept.
E_USERS_G = frozenset({70.0, 76.0})
E_USERS_M = frozenset({66.0, 67.0, 68.0})


def _rs274_m_words(code: float) -> str:
    """What rs274 without a configuration says of M``code``."""
    if code != int(code):
        return "Non integer value for integer"
    return "M-code greater than 199" if code >= 200 else "Unknown m code used"


def m_refusal(code: float) -> str | None:
    """Why a block with M``code`` is refused (None: LinuxCNC runs it, or a configuration may
    define it: see ``m_note``). Not for SINUMERIK."""
    if code == int(code) and int(code) in CONFIGURABLE_M:
        return None
    return (f"M{code:g} is not an M code the controller knows (LinuxCNC's rs274: '{_rs274_m_words(code)}'; "
            "a configuration can define only whole M codes up to M999): remove it")


def m_note(code: float) -> str | None:
    """The note for an M code a configuration must define (None: built in)."""
    if int(code) in LINUXCNC_M:
        return None
    return (f"M{int(code)} is not built into LinuxCNC (rs274 without a configuration: '{_rs274_m_words(code)}'); "
            "read as a code the machine's configuration defines (REMAP, or a user M100-M199 program) that moves no axis: "
            "check that it does not move the machine")


def letter_refusal(letter: str) -> str | None:
    """Why a word of ``letter`` (upper case) is refused wherever it stands."""
    if letter in BAD_CHARACTER:
        return f"{letter} word inside a block (LinuxCNC's rs274: \"Bad character '{letter.lower()}' used\"): a line number only starts a block"
    return None


E_REFUSAL = ("E word with no G70, G76, M66, M67 or M68 to use it (LinuxCNC's rs274, word for word): "
             "an E word (a 3D printer's extruder) moves nothing this machine has; remove it")
