"""Design-review campaigns end to end: the page leads with the verdicts and every plot loads
(in headless Chromium where it is installed), the drawn values reach the results table and
the bag's metadata (read back with the ``mcap`` library's reader and plain YAML), the
navigation error ellipses, the non-zero exit of an unmet requirement, and a sensitivity
campaign on a real Dask scheduler that loses a worker and is resumed."""
from __future__ import annotations

import base64
import json
import math
import os
import re
import shutil
import signal
import subprocess
import threading
import time
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
import yaml

from gimbal_sim.campaign.results import read_results
from gimbal_sim.campaign.spec import spec_from_mapping
from gimbal_sim.campaign_cli import main as campaign_main
from gimbal_sim.experiments.registry import run_campaign

CHROMIUM = shutil.which("chromium")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
GYRO_Q, GYRO_R = "sensor_models.gimbal_gyro_bias_deg_h[0]", "sensor_models.gimbal_gyro_bias_deg_h[1]"
REVIEW = {"scenario": "sighting_land_vehicle", "variants": ["ekf_off"],
          "dispersions": {GYRO_Q: "normal(100, 50)", GYRO_R: "uniform(0, 200)"}, "sensitivity": "sobol", "samples": 4,
          "requirements": [{"metric": "navigation.radial_rate_nmi_h", "max": 0.5, "p": 0.5, "c": 0.9}]}


def _navigation_like_run(task, run_dir: Path) -> None:
    """A caller's own run: a navigation-like end error from the drawn values and the seed's
    noise, a bag (an MCAP file, metadata.yaml) the engine adds the drawn values to."""
    from mcap.writer import Writer

    noise = np.random.default_rng(task.seed).normal(size=2)
    north = 1e-3 * task.values[GYRO_Q] + 0.05 * noise[0]
    east = 1e-3 * task.values[GYRO_R] + 0.05 * noise[1]
    (run_dir / "report").mkdir()
    (run_dir / "report" / "metrics.json").write_text(json.dumps({"navigation": {
        "north_error_m": north, "east_error_m": east, "radial_rate_nmi_h": math.hypot(north, east)}}))
    with open(run_dir / f"{run_dir.name}_0.mcap", "wb") as f:
        writer = Writer(f)
        writer.start()
        writer.finish()
    (run_dir / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": {
        "version": 9, "storage_identifier": "mcap", "relative_file_paths": [f"{run_dir.name}_0.mcap"],
        "custom_data": {}}}))


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: list[tuple[str, dict]] = []
        self.headings: list[str] = []
        self._h2 = False

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        self._h2 = tag == "h2"

    def handle_data(self, data):
        if self._h2:
            self.headings.append(data)
            self._h2 = False


def _chromium_counts(page: Path, tmp: Path) -> tuple[int, int]:
    """(images, images decoded) of ``page`` as headless Chromium loads it."""
    check = page.with_name("_check.html")
    script = ("<script>window.addEventListener('load',()=>{const i=[...document.images];"
              "console.log('PAGE-CHECK '+i.length+' '+i.filter(x=>x.complete&&x.naturalWidth>0).length);});</script>")
    check.write_text(page.read_text(encoding="utf-8").replace("</body>", script + "</body>"))
    run = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", f"--user-data-dir={tmp / 'p'}",
                          "--no-first-run", "--disable-component-update", "--disable-background-networking",
                          "--enable-logging=stderr", "--v=0", f"--screenshot={tmp / 'shot.png'}", check.as_uri()],
                         capture_output=True, text=True, timeout=120)
    check.unlink()
    found = re.search(r"PAGE-CHECK (\d+) (\d+)", run.stderr)
    assert run.returncode == 0 and found, run.stderr[-2000:]
    return int(found.group(1)), int(found.group(2))


def test_review_page_leads_with_the_verdict_and_every_plot_loads(tmp_path):
    out = tmp_path / "c"
    result = run_campaign(spec_from_mapping(REVIEW), out, serial=True, progress=False, run_fn=_navigation_like_run)
    rows = read_results(out)
    design = yaml.safe_load((out / "campaign.yaml").read_text())["design"]["ekf_off"]
    assert len(design) == 4 * (2 + 1 + 2) and len(rows) == len(set(design)) == len(result.rows)
    for row in rows:  # each run's drawn values: in its row, and in its bag's metadata
        values = json.loads((out / "runs" / row["run_id"] / "result.json").read_text())["values"]
        assert row[f"dispersed.{GYRO_Q}"] == values[GYRO_Q] and row[f"dispersed.{GYRO_R}"] == values[GYRO_R]
        custom = yaml.safe_load((out / "runs" / row["run_id"] / "metadata.yaml").read_text())[
            "rosbag2_bagfile_information"]["custom_data"]
        assert json.loads(custom[f"campaign.value.{GYRO_R}"]) == values[GYRO_R]
        assert custom["campaign.seed"] == str(row["seed"])
    summary = json.loads((out / "report" / "summary.json").read_text())
    (verdict,) = summary["requirements"]
    radial = np.array([r["navigation.radial_rate_nmi_h"] for r in rows])
    assert verdict["verdict"] == ("met" if np.sort(radial)[verdict["rank"] - 1] <= 0.5 else "not met")
    ellipse = summary["horizontal_error"]["ekf_off"]
    north, east = (np.array([r[f"navigation.{k}_error_m"] for r in rows]) for k in ("north", "east"))
    assert ellipse["cep50_m"] == pytest.approx(np.median(np.hypot(east, north)))
    assert np.allclose(ellipse["cov_en_m2"], np.cov(east, north))
    factors = summary["sensitivity"]["indices"]["ekf_off"]["navigation.north_error_m"]["factors"]
    assert set(factors) == {GYRO_Q, GYRO_R, "seed (noise)"}
    assert {"scatter.png", "horizontal_error.png", "sensitivity.png"} <= set(summary["plots"])
    assert any(p.startswith("convergence__navigation.radial_rate_nmi_h") for p in summary["plots"])
    assert summary["table"].startswith("REQUIREMENT navigation.radial_rate_nmi_h <= 0.5")

    page = out / "report" / "index.html"
    parser = _Tags()
    parser.feed(page.read_text(encoding="utf-8"))
    assert parser.headings[:3] == ["Requirements", "Sensitivity", "Campaign"], parser.headings
    assert verdict["verdict"].upper() in page.read_text(encoding="utf-8").split("<h2>Sensitivity")[0]
    images = [a["src"] for tag, a in parser.tags if tag == "img"]
    assert len(images) == len(list((out / "report").glob("*.png"))) >= 6
    assert all(base64.b64decode(src.split(",", 1)[1]).startswith(PNG_MAGIC) for src in images)
    if CHROMIUM is None:
        pytest.skip("no `chromium` binary on PATH (Debian: apt-get install chromium): the HTML was checked, "
                    "not its rendering")
    assert _chromium_counts(page, tmp_path) == (len(images), len(images))


def test_an_unmet_requirement_exits_3_with_its_verdict(tmp_path, capsys):
    out = tmp_path / "c"
    code = campaign_main(["sighting_land_vehicle", "--variant", "ekf_off", "--engine", "core", "--duration", "0.3",
                          "--seeds", "1", "--serial", "--no-progress", "--keep-bags", "none", "--out", str(out),
                          "--require", "|sighting.final_drift_deg.azimuth|<=1e-9,p=0.5,c=0.5"])
    captured = capsys.readouterr()
    assert code == 3, captured.err[-2000:]
    assert "REQUIREMENT |sighting.final_drift_deg.azimuth| <= 1e-09" in captured.out
    assert "not met" in captured.err


def _kill_first_busy_worker(client, pids: dict, killed: list, stop: threading.Event) -> None:
    """SIGKILL the first worker seen processing one of the campaign's runs (its nanny restarts it)."""
    while not stop.is_set() and not killed:
        for worker, keys in client.processing().items():
            if any(str(k).startswith("gimbal-campaign-") for k in keys) and worker in pids:
                os.kill(pids[worker], signal.SIGKILL)
                killed.append(worker)
                return
        time.sleep(0.05)


def test_sensitivity_campaign_on_a_dask_scheduler_survives_a_killed_worker_and_resumes(tmp_path):
    from distributed import Client, LocalCluster

    spec = spec_from_mapping({"scenario": "sighting_land_vehicle", "variants": ["ekf_off"], "engine": "core",
                              "duration_s": 0.3, "keep_bags": "none", "dispersions": {GYRO_R: "normal(100, 200)"},
                              "sensitivity": "sobol", "samples": 2})
    out = tmp_path / "c"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as client:
        pids = client.run(os.getpid)
        killed: list[str] = []
        stop = threading.Event()
        killer = threading.Thread(target=_kill_first_busy_worker, args=(client, pids, killed, stop))
        killer.start()
        try:
            first = run_campaign(spec, out, scheduler=cluster.scheduler_address, progress=False)
        finally:
            stop.set()
            killer.join()
        assert killed, "no worker was seen processing a run"
        assert len(first.rows) == 2 * (1 + 1 + 2) and not first.failed, [r["reason"] for r in first.failed]
        summary = json.loads((out / "report" / "summary.json").read_text())
        again = run_campaign(spec, out, scheduler=cluster.scheduler_address, resume=True, progress=False)
    assert (again.ran, again.skipped) == (0, len(first.rows))
    assert json.loads((out / "report" / "summary.json").read_text())["sensitivity"] == summary["sensitivity"]
    indices = summary["sensitivity"]["indices"]["ekf_off"]["sighting.final_drift_deg.azimuth"]["factors"]
    assert set(indices) == {GYRO_R, "seed (noise)"}
