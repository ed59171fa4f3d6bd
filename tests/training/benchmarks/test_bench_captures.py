"""training.benchmarks.bench_captures: each capture's time beside its out-of-fold accuracy."""
from training.benchmarks import bench_captures

TIMES = {"one JPEG": 0.05, "3 brackets": 0.2, "5 brackets": 0.25, "HDR clipped at +2 stops": 0.13,
         "HDR clipped at +4 stops": 0.14, "HDR clipped at +6 stops": 0.16, "RAW, white at +2 stops": 0.2}


def test_every_capture_finds_its_study_row_and_draws(tmp_path):
    summary = bench_captures.study_rows(bench_captures.DOCS / "captures.json", bench_captures.DOCS / "captures_raw.json")
    assert all(row in summary for row in bench_captures.STUDY_ROWS.values())  # the study names what it measured
    lines = bench_captures.table(TIMES, summary)
    assert len(lines) == 2 + len(TIMES) and "n/a" not in "".join(lines)
    assert lines[3].startswith("| 3 brackets | 0.200 | 4.00x | ")
    assert bench_captures.plot(TIMES, summary, tmp_path / "t.png").stat().st_size > 10_000


def test_a_capture_the_study_lacks_is_said_not_guessed():
    lines = bench_captures.table({"one JPEG": 0.05, "RAW, white at +2 stops": 0.2}, {})
    assert lines[-1] == "| RAW, white at +2 stops | 0.200 | 4.00x | n/a | n/a | n/a |"
