"""Diagnosis: compare model and measurement, say where the model fails and which
physical effect is missing (see :mod:`.residuals` for the statistics)."""

from .residuals import ResidualAnalysis, analyse_residuals, describe_structure, effective_sample_size

__all__ = ["ResidualAnalysis", "analyse_residuals", "describe_structure", "effective_sample_size"]
