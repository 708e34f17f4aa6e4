"""The CPU accuracy study with the fine scan of ln μ switched off (FINE_SCAN_MISFIT = ∞), all else as the code
at this commit: separates what the scan changes from what other changes since the previous study changed.
Run from the repository root (STUDY_FILE, default sweeps/detect_study.toml, picks the study file):
    python docs/logs/detection/study_without_scan.py --out docs/logs/detection/study_cpu_noscan.json
"""
import math
import os
import sys

import hertzian.ensemble.detect as detect_module
from hertzian.ensemble.cli import main

detect_module.FINE_SCAN_MISFIT = math.inf
sys.argv = ["hertzian", "detect-study", os.environ.get("STUDY_FILE", "sweeps/detect_study.toml"), "--device", "cpu",
            *sys.argv[1:]]
main()
