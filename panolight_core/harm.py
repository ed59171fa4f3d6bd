"""EVALUATION.md's "Harm", in one place: the evaluation reports it (``metrics``) and the estimators' decisions avoid
it (``estimators.sources.decision``), so it lives below both."""
from __future__ import annotations

HARM_RATIO, HARM_MARGIN = 2.0, 0.25  # EVALUATION.md "Harm"


def harmed(m_rmse: float, as_is: float) -> bool:
    """EVALUATION.md's harm: the whole model's m-RMSE above both HARM_RATIO times and HARM_MARGIN over the input's
    as-is projection's (the naive one for an 8-bit input, the file's own for an HDR, the ev-0 frame's naive one for a
    bracket set). Reported first, before medians and means."""
    return m_rmse > HARM_RATIO * as_is and m_rmse > as_is + HARM_MARGIN
