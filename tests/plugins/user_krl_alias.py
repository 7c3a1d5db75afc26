"""A test plugin dialect (NOT built in): KRL under another name and file extension."""

from __future__ import annotations

from postproc.programs.dialects import get

KrlDialect = type(get("krl"))


class UserKrl(KrlDialect):
    name = "user_krl"
    description = "KRL, as written by our cell's offline programming tool (.usrc)"
    extensions = (".usrc",)


USER_KRL = UserKrl()
