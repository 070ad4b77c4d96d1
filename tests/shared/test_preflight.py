"""The machine checks name what is missing and how to install it."""

from __future__ import annotations

from pathlib import Path

from manigraph_shared.preflight import vulkan_drivers, vulkan_problem


def test_the_loader_variable_decides_which_vulkan_drivers_count(tmp_path: Path) -> None:
    driver = tmp_path / "lvp_icd.json"
    driver.write_text("{}")
    assert vulkan_drivers({"VK_ICD_FILENAMES": str(driver)}) == [driver]
    assert vulkan_problem("the camera", {"VK_DRIVER_FILES": str(driver)}) is None
    missing = {"VK_ICD_FILENAMES": str(tmp_path / "none.json")}
    assert vulkan_drivers(missing) == []
    problem = vulkan_problem("the camera", missing)
    assert problem is not None
    assert problem.startswith("the camera needs a Vulkan device")
    assert "VK_ICD_FILENAMES=" in problem and "make vulkan" in problem


def test_drivers_are_found_under_the_data_dirs(tmp_path: Path) -> None:
    icd = tmp_path / "vulkan" / "icd.d"
    icd.mkdir(parents=True)
    (icd / "x_icd.json").write_text("{}")
    assert icd / "x_icd.json" in vulkan_drivers({"XDG_DATA_DIRS": str(tmp_path)})
