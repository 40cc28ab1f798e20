"""The Python package against the Rust library and the `fdid` command."""

import json
import os
import pathlib
import subprocess
import threading
import time

import numpy as np
import pytest

import fdid

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "data"


def fdid_command():
    """The `fdid` program: $FDID, else the release build of the repository. CI sets
    FDID, and then a missing program is a failure, not a skip."""
    path = os.environ.get("FDID")
    if path:
        assert os.access(path, os.X_OK), f"FDID={path} is not an executable"
        return path
    path = ROOT / "target" / "release" / "fdid"
    if not path.exists():
        pytest.skip("no fdid program (cargo build --release, or set FDID)")
    return str(path)


def second_order(f, wn=2.0, zeta=0.1, gain=1.0):
    s = 2j * np.pi * f
    return gain * wn**2 / (s**2 + 2 * zeta * wn * s + wn**2)


def test_noise_free_continuous_time_recovery():
    f = np.linspace(0.01, 2.0, 300)
    fit = fdid.fit(f, second_order(f), domain="s", na=2, nb=0)
    want = np.roots([1.0, 0.4, 4.0])
    assert np.allclose(np.sort_complex(fit.poles), np.sort_complex(want), rtol=0, atol=1e-10)
    assert fit.gain == pytest.approx(4.0, rel=1e-10)
    assert fit.zeros.size == 0 and fit.domain == "s" and fit.ts is None
    assert fit.stable and fit.lines == 300 and fit.delay is None
    g = fit.frf(np.array([0.05, 0.5, 3.0]))
    assert np.allclose(g, second_order(np.array([0.05, 0.5, 3.0])), rtol=1e-10)


def test_noise_free_discrete_time_recovery_with_a_delay():
    ts = 0.1
    f = np.linspace(0.02, 4.9, 250)
    z = np.exp(2j * np.pi * f * ts)
    tau = 0.23  # s: 2.3 samples
    g = (0.2 + 0.1 / z) / (1 - 1.2 / z + 0.5 / z**2) * np.exp(-2j * np.pi * f * tau)
    fit = fdid.fit(f, g, domain="z", ts=ts, na=2, nb=1, delay=True)
    assert fit.delay == pytest.approx(tau, abs=1e-8)
    assert np.allclose(np.sort_complex(fit.poles), np.sort_complex(np.roots([1, -1.2, 0.5])), atol=1e-8)
    assert fit.ts == ts and fit.domain == "z"


def test_noise_weighted_fit_has_a_covariance_and_a_cost_test():
    rng = np.random.default_rng(3)
    f = np.linspace(0.01, 2.0, 400)
    sigma = 0.01
    noise = sigma / np.sqrt(2) * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    fit = fdid.fit(f, second_order(f) + noise, domain="s", na=2, nb=0, var=np.full(f.size, sigma**2))
    cov = fit.covariance
    assert cov.shape == (3, 3) and np.allclose(cov, cov.T)
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    v = fit.validation
    # a correct model: the cost is a draw of its null distribution
    assert v["cost_p"] is not None and 1e-3 < v["cost_p"] < 1 - 1e-3
    assert fit.cost == pytest.approx(v["cost"], rel=1e-9)
    std = fit.frf_std(f[:5])
    assert std.shape == (5,) and np.all(std > 0) and np.all(std < 10 * sigma)


def test_same_result_as_the_command():
    path = DATA / "eis_battery.csv"
    out = subprocess.run(
        [fdid_command(), "fit", str(path), "--domain", "s", "--na", "3", "--nb", "3", "--band", ":1000", "--json"],
        check=True,
        capture_output=True,
        text=True,
    )
    cli = json.loads(out.stdout)
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    fit = fdid.fit(table[:, 0], table[:, 1] + 1j * table[:, 2], domain="s", na=3, nb=3, band=(0.0, 1000.0))
    cli_poles = np.array([complex(re, im) for re, im in cli["poles"]])
    assert np.allclose(np.sort_complex(fit.poles), np.sort_complex(cli_poles), rtol=1e-9, atol=0)
    assert fit.cost == pytest.approx(cli["cost"], rel=1e-9)
    assert fit.gain == pytest.approx(cli["gain"], rel=1e-9)
    assert fit.lines == cli["lines"]


def test_saved_model_round_trip_and_fdid_eval(tmp_path):
    f = np.linspace(0.01, 2.0, 200)
    fit = fdid.fit(f, second_order(f, zeta=0.05), domain="s", na=2, nb=1)
    text = fit.to_json()
    again = fdid.load(text)
    probe = np.array([0.1, 0.3, 0.7, 1.9])
    assert np.array_equal(again.frf(probe), fit.frf(probe))
    assert np.array_equal(again.theta, fit.theta)
    saved = tmp_path / "model.json"
    saved.write_text(text)
    assert np.array_equal(fdid.load(saved).poles, fit.poles)
    # the command reads what Python saved, to the last bit
    out = subprocess.run(
        [fdid_command(), "eval", str(saved), "--freq", "0.1,0.3,0.7,1.9", "--json"],
        check=True,
        capture_output=True,
        text=True,
    )
    cli = np.array([complex(re, im) for _, re, im in json.loads(out.stdout)["frf"]])
    assert np.array_equal(cli, fit.frf(probe))


def test_a_model_saved_by_the_command_loads(tmp_path):
    saved = tmp_path / "eis.json"
    subprocess.run(
        [fdid_command(), "fit", str(DATA / "eis_battery.csv"), "--domain", "s", "--na", "2", "--nb", "2", "--save", str(saved)],
        check=True,
        capture_output=True,
    )
    model = fdid.load(saved)
    assert model.poles.size == 2 and model.validation is None


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda f, g: fdid.fit(f, g[:-1], domain="s", na=2, nb=0), "one per frequency"),
        (lambda f, g: fdid.fit(f.reshape(2, -1), g, domain="s", na=2, nb=0), "one-dimensional"),
        (lambda f, g: fdid.fit(f, np.where(f > 1, np.nan, g), domain="s", na=2, nb=0), r"frf\[50\] = NaN.* is not finite"),
        (lambda f, g: fdid.fit(np.where(f > 1, np.inf, f), g, domain="s", na=2, nb=0), r"f\[50\] is not finite"),
        # the frequencies are reported as given, in Hz
        (lambda f, g: fdid.fit(f[::-1], g, domain="s", na=2, nb=0), r"f must increase: f\[1\] = 1\.9798.* Hz follows f\[0\] = 2"),
        (lambda f, g: fdid.fit(f - 0.5, g, domain="s", na=2, nb=0), r"f\[0\] = -0\.49 Hz is negative"),
        (lambda f, g: fdid.fit(f, g, domain="q", na=2, nb=0), "domain"),
        (lambda f, g: fdid.fit(f, g, domain="z", na=2, nb=0), "ts="),
        (lambda f, g: fdid.fit(f, g, domain="s", ts=0.1, na=2, nb=0), "sample time"),
        (lambda f, g: fdid.fit(f, g, domain="s", na=2, nb=0, criterion="magic"), "criterion"),
        (lambda f, g: fdid.fit(f[:2], g[:2], domain="s", na=4, nb=3), "frequencies"),
        (lambda f, g: fdid.fit(f, g, domain="s", na=2, nb=0, var=-np.ones(f.size)), "variance"),
        (lambda f, g: fdid.fit(f, g, domain="s", na=2, nb=0, band=(50.0, 60.0)), "band"),
        (lambda f, g: fdid.fit(f, ["a"] * f.size, domain="s", na=2, nb=0), "numbers"),
        (lambda f, g: fdid.load("{\"format\": \"other\"}"), "not a saved fdid model"),
    ],
)
def test_bad_input_is_a_value_error(call, message):
    f = np.linspace(0.01, 2.0, 100)
    with pytest.raises(ValueError, match=message):
        call(f, second_order(f))


def test_fits_in_threads_agree():
    f = np.linspace(0.01, 2.0, 2000)
    want = fdid.fit(f, second_order(f), domain="s", na=2, nb=0).poles
    results = [None] * 4

    def run(k):
        results[k] = fdid.fit(f, second_order(f), domain="s", na=2, nb=0).poles

    threads = [threading.Thread(target=run, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert all(np.array_equal(r, want) for r in results)


class FakeNetwork:
    """The two attributes of a scikit-rf Network that fdid reads."""

    def __init__(self, f, s):
        self.f = f
        self.s = s


def test_from_network_fits_the_named_entry():
    f = np.linspace(1e6, 1e8, 200)
    s = np.zeros((f.size, 2, 2), dtype=complex)
    s[:, 1, 0] = second_order(f, wn=2 * np.pi * 3e7, zeta=0.2)
    fit = fdid.from_network(FakeNetwork(f, s), port=(2, 1), na=2, nb=0)
    assert np.allclose(np.abs(fit.poles), 2 * np.pi * 3e7, rtol=1e-8)
    with pytest.raises(ValueError, match="outside"):
        fdid.from_network(FakeNetwork(f, s), port=(3, 1), na=2, nb=0)


def test_from_network_with_scikit_rf():
    skrf = pytest.importorskip("skrf")
    net = skrf.Network(str(DATA / "rlc_bandpass.s2p"))
    fit = fdid.from_network(net, port=(2, 1), na=2, nb=1)
    assert fit.lines == len(net.f) and fit.stable


def test_the_examples_in_the_docstrings_run():
    import doctest

    failed, tried = doctest.testmod(fdid)
    assert tried > 0 and failed == 0


def load_csv(name):
    table = np.loadtxt(DATA / name, delimiter=",", skiprows=1)
    return table[:, 0], table[:, 1], table[:, 2]


def run_json(*args):
    out = subprocess.run([fdid_command(), *args, "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def poles_of(cli):
    return np.sort_complex(np.array([complex(re, im) for re, im in cli["poles"]]))


def test_record_fit_is_the_command_s():
    t, u, y = load_csv("dryer.csv")
    cli = run_json("fit", str(DATA / "dryer.csv"), "--domain", "z", "--na", "2", "--nb", "2", "--transient")
    fit = fdid.fit_record(t, u, y, domain="z", na=2, nb=2, transient=True)
    assert fit.ts == pytest.approx(0.08, rel=1e-12)
    assert np.allclose(np.sort_complex(fit.poles), poles_of(cli), rtol=1e-9, atol=0)
    assert fit.cost == pytest.approx(cli["cost"], rel=1e-9)
    assert fit.lines == cli["lines"]


def test_periodic_record_is_averaged_and_weighted(tmp_path):
    rng = np.random.default_rng(5)
    m, p = 256, 6
    period = rng.standard_normal(m)
    u = np.tile(period, p)
    # y(t) = 0.3 u(t-1) + 1.2 y(t-1) - 0.5 y(t-2), in steady state, plus noise
    y = np.zeros(u.size + 2 * m)
    uu = np.concatenate([np.tile(period, 2), u])
    for k in range(2, uu.size):
        y[k] = 0.3 * uu[k - 1] + 1.2 * y[k - 1] - 0.5 * y[k - 2]
    y = y[2 * m :] + 1e-3 * rng.standard_normal(u.size)
    t = np.arange(u.size) * 0.01
    fit = fdid.fit_record(t, u, y, domain="z", na=2, nb=1, periods=p)
    assert np.allclose(np.sort_complex(fit.poles), np.sort_complex(np.roots([1, -1.2, 0.5])), atol=2e-3)
    # weighted by the sample variances: a correct model passes the cost test
    assert fit.validation["cost_p"] is not None and fit.validation["cost_p"] > 1e-3
    path = tmp_path / "periodic.csv"
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header="t,u,y", comments="", fmt="%.17g")
    cli = run_json("fit", str(path), "--domain", "z", "--na", "2", "--nb", "1", "--periods", str(p))
    assert np.allclose(np.sort_complex(fit.poles), poles_of(cli), rtol=1e-9, atol=0)
    assert fit.cost == pytest.approx(cli["cost"], rel=1e-9)


def test_spectra_fit_recovers_the_system():
    rng = np.random.default_rng(2)
    f = np.linspace(0.02, 2.0, 150)
    u = rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)
    y = second_order(f) * u
    fit = fdid.fit_spectra(f, u, y, domain="s", na=2, nb=0)
    assert np.allclose(np.sort_complex(fit.poles), np.sort_complex(np.roots([1.0, 0.4, 4.0])), atol=1e-9)
    with pytest.raises(ValueError, match="one per frequency"):
        fdid.fit_spectra(f, u[:-1], y, domain="s", na=2, nb=0)
    with pytest.raises(ValueError, match="not finite"):
        fdid.fit_spectra(f, np.where(f > 1, np.inf, u), y, domain="s", na=2, nb=0)


def test_record_with_a_noise_model():
    rng = np.random.default_rng(7)
    n = 2048
    u = rng.standard_normal(n)
    e = 0.05 * rng.standard_normal(n)
    y = np.zeros(n)
    v = np.zeros(n)
    for k in range(1, n):
        v[k] = e[k] + 0.8 * v[k - 1]  # coloured noise 1/(1 - 0.8 z^-1)
        y[k] = 0.5 * u[k - 1] + 0.6 * y[k - 1]
    t = np.arange(n) * 1.0
    fit = fdid.fit_record(t, u, y + v, domain="z", na=1, nb=1, transient=True, noise_order=1)
    assert fit.poles.size == 1 and abs(fit.poles[0] - 0.6) < 0.02


def test_diagnose_names_the_dryer_delay_as_the_command_does():
    t, u, y = load_csv("dryer.csv")
    cli = run_json("diagnose", str(DATA / "dryer.csv"), "--domain", "z", "--ts", "0.08", "--na", "2", "--nb", "2")
    report = fdid.diagnose(t=t, u=u, y=y, domain="z", na=2, nb=2)
    assert report["effects"] == cli["effects"] == ["time_delay", "transient"]
    for step, want in zip(report["steps"], cli["steps"]):
        assert step["effect"] == want["effect"]
        assert step["cost_after"] == pytest.approx(want["cost_after"], rel=1e-9)
    assert report["consistent"]
    fit = report["fit"]
    # the reference: an input delay of 3 samples of 0.08 s
    assert abs(fit.delay / 0.08 - 3.0) < 0.5
    assert report["final_spec"]["delay"] and report["final_spec"]["transient"]


def test_diagnose_of_a_frequency_response_finds_a_missing_resonance():
    rng = np.random.default_rng(11)
    f = np.linspace(0.05, 3.0, 400)
    s = 2j * np.pi * f
    g = 4.0 / (s**2 + 0.4 * s + 4.0) * 25.0 / (s**2 + 0.5 * s + 25.0)
    sigma = 1e-3
    noisy = g + sigma / np.sqrt(2) * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    report = fdid.diagnose(f=f, frf=noisy, var=np.full(f.size, sigma**2), domain="s", na=2, nb=0)
    assert report["effects"][0] == "missing_resonance"
    assert report["final_spec"]["na"] >= 4 and report["consistent"]
    with pytest.raises(ValueError, match="f and frf"):
        fdid.diagnose(f=f, domain="s", na=2, nb=0)
    with pytest.raises(ValueError, match="alpha"):
        fdid.diagnose(f=f, frf=noisy, domain="s", na=2, nb=0, alpha=2.0)


def test_bad_time_grids_are_value_errors():
    t = np.arange(100) * 0.1
    u = np.sin(t)
    with pytest.raises(ValueError, match="non-uniform"):
        fdid.fit_record(np.r_[t[:50], t[50:] + 0.05], u, u, domain="z", na=1, nb=0)
    with pytest.raises(ValueError, match="increase"):
        fdid.fit_record(t[::-1], u, u, domain="z", na=1, nb=0)
    with pytest.raises(ValueError, match="excites no line"):
        fdid.fit_record(t, np.ones(100), u, domain="z", na=1, nb=0)


def test_fit_many_equals_one_by_one_and_reports_failures():
    rng = np.random.default_rng(4)
    f = np.linspace(0.01, 2.0, 200)
    sets = []
    for k in range(40):
        g = second_order(f, wn=1.0 + 0.05 * k, zeta=0.05 + 0.002 * k)
        sets.append((f, g + 1e-3 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))))
    fits = fdid.fit_many(sets, domain="s", na=2, nb=0)
    assert len(fits) == 40
    for (fk, gk), fit in zip(sets, fits):
        one = fdid.fit(fk, gk, domain="s", na=2, nb=0)
        assert np.array_equal(fit.poles, one.poles) and fit.cost == one.cost
    # dicts and variances too
    as_dicts = [{"f": f, "frf": g, "var": np.full(f.size, 2e-6)} for f, g in sets[:3]]
    assert all(fit.validation["cost_p"] is not None for fit in fdid.fit_many(as_dicts, domain="s", na=2, nb=0))
    bad = sets[:3] + [(f[:5], sets[3][1][:5])] + sets[4:6]
    with pytest.raises(ValueError, match="data set 3"):
        fdid.fit_many(bad, domain="s", na=6, nb=5)
    kept = fdid.fit_many(bad, domain="s", na=6, nb=5, errors="none")
    assert kept[3] is None and all(k is not None for i, k in enumerate(kept) if i != 3)
    with pytest.raises(ValueError, match="data set 1"):
        fdid.fit_many([sets[0], (f, sets[1][1][:-1])], domain="s", na=2, nb=0)
    with pytest.raises(ValueError, match="errors="):
        fdid.fit_many(sets[:1], domain="s", na=2, nb=0, errors="ignore")


def test_the_dask_example_task_runs_without_dask():
    import importlib.util

    spec = importlib.util.spec_from_file_location("dask_many", ROOT / "python" / "examples" / "dask_many.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    results = example.fit_batch(3, 20)
    _, truth = example.make_frfs(20, seed=3)
    assert len(results) == 20
    for (poles, p), (wn, zeta) in zip(results, truth):
        assert abs(np.abs(poles[0]) - wn) < 1e-2 * wn and p is not None


def test_bounds_hold_the_truth_about_as_often_as_their_level():
    rng = np.random.default_rng(8)
    f = np.linspace(0.01, 2.0, 300)
    probe = np.linspace(0.05, 1.9, 7)
    sigma = 0.02
    inside, total = 0, 0
    for _ in range(60):
        noise = sigma / np.sqrt(2) * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
        fit = fdid.fit(f, second_order(f) + noise, domain="s", na=2, nb=0, var=np.full(f.size, sigma**2))
        b = fit.bounds(probe, 0.9)
        lo, hi = b["magnitude"]
        truth = np.abs(second_order(probe))
        inside += np.sum((lo <= truth) & (truth <= hi))
        total += probe.size
        assert np.all(lo < np.abs(fit.frf(probe))) and np.all(np.abs(fit.frf(probe)) < hi)
        plo, phi = b["phase"]
        assert np.all(plo < phi)
    # 90 % bounds: 420 pointwise checks (correlated through the 60 fits)
    assert 0.8 < inside / total < 0.97
    with pytest.raises(ValueError, match="level"):
        fit.bounds(probe, 1.5)


def test_ltv_is_the_command_s(tmp_path):
    table = np.loadtxt(DATA / "silverbox.csv", delimiter=",", skiprows=1, max_rows=2999)
    path = tmp_path / "sb.csv"
    np.savetxt(path, table, delimiter=",", header="t,u,y", comments="", fmt="%.17g")
    cli = run_json("ltv", str(path), "--na", "2", "--nb", "0", "--np", "1", "--band", ":150")
    got = fdid.ltv(table[:, 0], table[:, 1], table[:, 2], na=2, nb=0, np=1, band=(0.0, 150.0))
    assert np.allclose(got["theta"], cli["theta"], rtol=1e-9, atol=1e-12)
    assert np.allclose(got["singular_values"][:3], cli["singular_values"][:3], rtol=1e-9)
    assert len(got["poles"]) == len(got["times"]) == 5 and all(p.size == 2 for p in got["poles"])
    # the Silverbox's resonance near 69.5 Hz at every instant
    for p in got["poles"]:
        assert 60 < np.abs(p[0]) / (2 * np.pi) < 80
    with pytest.raises(ValueError, match="basis"):
        fdid.ltv(table[:, 0], table[:, 1], table[:, 2], na=2, nb=0, np=1, basis="fourier")
    with pytest.raises(ValueError, match="Nyquist"):
        fdid.ltv(table[:, 0], table[:, 1], table[:, 2], na=2, nb=0, np=1, band=(0.0, 1e6))


def python_blocks(path):
    """The ```python code blocks of a Markdown file."""
    text = path.read_text(encoding="utf-8")
    blocks, inside, current = [], False, []
    for line in text.splitlines():
        if line.strip() == "```python":
            inside, current = True, []
        elif inside and line.strip() == "```":
            inside = False
            blocks.append("\n".join(current))
        elif inside:
            current.append(line)
    return blocks


@pytest.mark.parametrize("page", ["README.md", "docs/python.md"])
def test_the_python_examples_of_the_docs_run(page, tmp_path, monkeypatch):
    blocks = python_blocks(ROOT / page)
    assert blocks, f"{page} has no python block"
    # the examples read the bundled data from the repository root and may write files
    (tmp_path / "data").symlink_to(DATA)
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, page, "exec"), {})


def read_s2p_db(path):
    """f (Hz) and S (N × 2 × 2) of a version 1 two-port Touchstone file in MHz, dB/deg."""
    rows = []
    for line in path.read_text().splitlines():
        line = line.split("!")[0].strip()
        if line and not line.startswith("#"):
            rows.append([float(v) for v in line.split()])
    rows = np.array(rows)
    f = rows[:, 0] * 1e6
    values = 10 ** (rows[:, 1::2] / 20) * np.exp(1j * np.deg2rad(rows[:, 2::2]))
    # file order S11 S21 S12 S22
    s = np.empty((f.size, 2, 2), dtype=complex)
    s[:, 0, 0], s[:, 1, 0], s[:, 0, 1], s[:, 1, 1] = values.T
    return f, s


def test_common_poles_are_the_command_s_on_the_rlc_two_port():
    path = DATA / "rlc_bandpass.s2p"
    cli = run_json("fit", str(path), "--domain", "s", "--na", "2", "--nb", "2")
    f, s = read_s2p_db(path)
    fit = fdid.fit_common_poles(f, s, domain="s", order=2)
    assert np.allclose(np.sort_complex(fit.poles), poles_of(cli), rtol=1e-9, atol=0)
    assert fit.rms == pytest.approx(cli["rms_error"], rel=1e-6)
    # the series RLC: L C s^2 + (R + 2 Z0) C s + 1 with R = 5, L = 1e-6, C = 1e-9
    want = np.roots([1e-15, 105e-9, 1.0])
    assert np.allclose(np.sort_complex(fit.poles), np.sort_complex(want), rtol=1e-4)
    g = fit.frf(f[:3])
    assert g.shape == (3, 2, 2) and np.allclose(g, s[:3], atol=1e-5)
    net = FakeNetwork(f, s)
    assert np.array_equal(fdid.from_network(net, port=None, order=2).poles, fit.poles)


def test_common_poles_recover_a_three_by_two_system():
    f = np.linspace(0.05, 3.0, 300)
    s = 2j * np.pi * f
    poles = [complex(-0.1, 2.0), complex(-0.3, 9.0)]
    rng = np.random.default_rng(6)
    g = np.zeros((f.size, 3, 2), dtype=complex)
    for p in poles:
        r = rng.standard_normal((3, 2)) + 1j * rng.standard_normal((3, 2))
        g += r[None] / (s - p)[:, None, None] + r.conj()[None] / (s - np.conj(p))[:, None, None]
    fit = fdid.fit_common_poles(f, g, domain="s", order=4, direct=False)
    want = np.sort_complex(np.array(poles + [p.conjugate() for p in poles]))
    assert np.allclose(np.sort_complex(fit.poles), want, atol=1e-8)
    assert fit.residues.shape == (2, 3, 2) and fit.direct is None and fit.stable
    modes = fit.modes
    assert [round(m["f_n_hz"] * 2 * np.pi, 6) for m in modes] == [round(abs(p), 6) for p in poles]
    ss = fit.state_space
    # one block of the poles per input: 4 × 2 states
    assert ss["a"].shape == (8, 8) and ss["b"].shape == (8, 2) and ss["c"].shape == (3, 8)
    # the realisation reproduces the response: C (sI − A)⁻¹ B + D
    k = 17
    h = ss["c"] @ np.linalg.solve(s[k] * np.eye(8) - ss["a"], ss["b"]) + ss["d"]
    assert np.allclose(h, g[k], atol=1e-8)
    with pytest.raises(ValueError, match="outputs, inputs"):
        fdid.fit_common_poles(f, g[:, 0, :], domain="s", order=4)
    with pytest.raises(ValueError, match="one per frequency"):
        fdid.fit_common_poles(f[:-1], g, domain="s", order=4)
    with pytest.raises(ValueError, match="not finite"):
        bad = g.copy()
        bad[5, 2, 1] = np.nan
        fdid.fit_common_poles(f, bad, domain="s", order=4)


def test_the_gil_is_released_during_a_fit():
    # a fit of a tenth of a second or more in a thread: the main thread, waking every
    # millisecond, runs meanwhile only if the fit does not hold the GIL
    f = np.linspace(0.01, 2.0, 200_000)
    g = second_order(f) * (1 + 1e-3 * np.sin(37 * f))
    done = threading.Event()
    seconds = []

    def run():
        seconds.append(fdid.fit(f, g, domain="s", na=2, nb=0).fit_seconds)
        done.set()

    thread = threading.Thread(target=run)
    ticks = 0
    thread.start()
    while not done.is_set():
        time.sleep(0.001)
        ticks += 1
    thread.join()
    # at least a tick per 10 ms of the fit (about one per 1–2 ms when released)
    assert ticks >= max(3, seconds[0] / 0.01), (ticks, seconds[0])
