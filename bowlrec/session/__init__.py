"""Sessions: bowlers throwing games on one lane whose oil changes shot by shot
(:mod:`bowlrec.session.spec`, :mod:`bowlrec.session.runner`, :mod:`bowlrec.session.records`,
:mod:`bowlrec.session.figures`; docs/sessions.md)."""
