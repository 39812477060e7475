"""Analysis of point sets on the unit torus, by the conventions of docs/architecture.md ("Analysis conventions") (see
docs/analysis.md): power spectra (2-D grid, 1-D projections, 2-D subspaces, n-D Monte Carlo
radial mean), anisotropy, pair correlation, minimum-distance ratio, discrepancies and a Monte
Carlo integration study. Every function takes one set (m, n) or a batch (sets, m, n) and
averages over the sets. Pure numpy/scipy: no compiled dpc code is needed.

    >>> from dpc import analysis, baselines
    >>> sets = baselines.generate("jitter", 1024, count=16)
    >>> r = analysis.radial_spectrum(sets)          # radial mean + anisotropy
    >>> r.low_frequency_energy(0.5), r.peak()
"""

from ._common import as_sets, max_packing_distance
from .discrepancy import METHODS as DISCREPANCY_METHODS
from .discrepancy import discrepancy, discrepancy_per_set, generalized_l2, unanchored_l2
from .integration import (
    FAMILIES,
    IntegrandFamily,
    IntegrationStudy,
    estimates,
    integrands,
    integration_study,
    relative_variance,
)
from .pcf import PCF, MinDistance, min_distance, min_distance_ratio, pair_statistics, pcf
from .reference import ReferenceCopy, reference_copied_from, reference_radial_spectrum, reference_spectrum_copies
from .report import Analysis, analyze
from .spectrum import (
    RadialSpectrum,
    Spectrum1D,
    Spectrum2D,
    frequencies_below,
    low_frequency_energy,
    power_spectrum_1d,
    power_spectrum_2d,
    power_spectrum_direct,
    radial_profile,
    radial_spectrum,
    radial_spectrum_mc,
)

__all__ = [
    "as_sets",
    "max_packing_distance",
    "power_spectrum_2d",
    "power_spectrum_1d",
    "power_spectrum_direct",
    "low_frequency_energy",
    "frequencies_below",
    "radial_profile",
    "radial_spectrum",
    "radial_spectrum_mc",
    "Spectrum2D",
    "Spectrum1D",
    "RadialSpectrum",
    "pcf",
    "PCF",
    "pair_statistics",
    "min_distance",
    "min_distance_ratio",
    "MinDistance",
    "discrepancy",
    "discrepancy_per_set",
    "generalized_l2",
    "unanchored_l2",
    "DISCREPANCY_METHODS",
    "integrands",
    "IntegrandFamily",
    "estimates",
    "relative_variance",
    "integration_study",
    "IntegrationStudy",
    "FAMILIES",
    "analyze",
    "Analysis",
    "reference_radial_spectrum",
    "reference_spectrum_copies",
    "reference_copied_from",
    "ReferenceCopy",
]
