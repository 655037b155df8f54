"""Sessions: bowlers throwing games on one lane whose oil changes shot by shot
(:mod:`bowlrec.session.spec`, :mod:`bowlrec.session.runner`, :mod:`bowlrec.session.records`;
its figures are :mod:`bowlrec.figures.session`; docs/sessions.md)."""
