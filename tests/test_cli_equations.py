"""`anadyn equations`: output and exit codes."""
from anadyn_cli.cli import main


def test_rr_equations_print_the_chapter_form(capsys):
    assert main(["equations", "robots/rr.yaml"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "# kane equations, numeric parameters"
    assert out[1] == ("q1: -T01z + T12z + 1.3333333*ddq1 + 0.5*ddq2*cos(q1 - q2) "
                      "+ 0.5*dq2**2*sin(q1 - q2) + 14.715*cos(q1) = 0")
    assert out[2] == ("q2: -T12z + 0.5*ddq1*cos(q1 - q2) + 0.33333333*ddq2 "
                      "- 0.5*dq1**2*sin(q1 - q2) + 4.905*cos(q2) = 0")


def test_lagrange_prints_the_same_equations(capsys):
    main(["equations", "robots/rr.yaml"])
    kane = capsys.readouterr().out.splitlines()[1:]
    assert main(["equations", "robots/rr.yaml", "--formulation", "lagrange"]) == 0
    assert capsys.readouterr().out.splitlines()[1:] == kane


def test_symbolic_matrices(capsys):
    assert main(["equations", "robots/rr.yaml", "--symbolic", "--matrices"]) == 0
    out = capsys.readouterr().out
    assert "M[1,1] = L1**2*m1/3 + L1**2*m2" in out
    assert "M[1,2] = L1*L2*m2*cos(q1 - q2)/2" in out
    assert "B[1,2] = -1" in out


def test_latex(capsys):
    assert main(["equations", "robots/rrt.yaml", "--format", "latex"]) == 0
    assert r"\cos{\left(q_{2} \right)}" in capsys.readouterr().out


def test_missing_file_is_one_line_and_exit_2(capsys):
    assert main(["equations", "no/such.yaml"]) == 2
    assert capsys.readouterr().err == "anadyn: error: no/such.yaml: no such file\n"


def test_malformed_yaml_is_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "broken.yaml"
    bad.write_text("name: broken\nbodies: [\n")
    assert main(["equations", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err == (f"anadyn: error: {bad}:3: not valid YAML: expected the node content, "
                   "but found '<stream end>'\n")


def test_unknown_method_is_a_usage_error(capsys):
    assert main(["equations", "robots/rr.yaml", "--formulation", "newton"]) == 2
    assert "newton" in capsys.readouterr().err


def test_a_large_printout_says_its_size_first(monkeypatch, capsys):
    import importlib

    monkeypatch.setattr(importlib.import_module("anadyn_cli.commands.equations"),
                        "LARGE_OUTPUT", 100)
    assert main(["equations", "robots/rr.yaml"]) == 0
    captured = capsys.readouterr()
    size = len(captured.out.encode("utf-8")) - 1          # echo adds the final newline
    assert captured.err == (f"anadyn: note: the equations of rr take {size / 1e6:.1f} MB "
                            f"({captured.out.count(chr(10))} lines); redirect them to a file\n")
