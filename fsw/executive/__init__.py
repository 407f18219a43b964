"""Frame executive: fixed-length simulated frames with a CPU (or work-unit) budget per frame."""

from fsw.executive.config import PRIORITY_CLASSES, BudgetConfig
from fsw.executive.executive import FrameExecutive, FrameTimeError
from fsw.executive.report import ICD_FIELDS, BudgetReportData, DrainResult, ExecutiveStats, StageError
from fsw.executive.work import Job, JobError, JobOrderError, Stage

__all__ = [
    "PRIORITY_CLASSES",
    "BudgetConfig",
    "FrameExecutive",
    "FrameTimeError",
    "ICD_FIELDS",
    "BudgetReportData",
    "DrainResult",
    "ExecutiveStats",
    "StageError",
    "Job",
    "JobError",
    "JobOrderError",
    "Stage",
]
