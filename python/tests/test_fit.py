"""The Python package against the Rust library and the `fdid` command."""

import json
import os
import pathlib
import subprocess
import threading

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
        (lambda f, g: fdid.fit(f, np.where(f > 1, np.nan, g), domain="s", na=2, nb=0), "not finite"),
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
