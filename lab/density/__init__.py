"""Blue noise that follows a density: the measured comparison of Model.generate_density with the
anchors (inverse-CDF warping, weighted sample elimination, variable-radius dart throwing, weighted
Lloyd relaxation). Run python -m lab.density.study [--quick]; it writes docs/reports/density.md."""
