"""Write models/repulsion-2d.onnx: a hand-designed (untrained) 2-D blue-noise cascade.

40 identical layers of a Gaussian repulsion kernel g(d) = -A exp(-d^2 / (2 sigma^2)), with d and g
in units of the mean point spacing (A = 0.3, sigma = 0.85, radius rho = 3.2 spacings, about 32
neighbours per point), trained count m = 1,024. The study in docs/architecture.md found such a fixed local repulsion
cascade already has less low-frequency energy than BNOT; it is the demo and benchmark model
until trained models ship, and the natural initialisation for training blue noise.

    python models/make_repulsion_2d.py            # writes models/repulsion-2d.onnx
"""

from pathlib import Path

import numpy as np

from dpc.model_file import Layer, ModelSpec, write_model

AMPLITUDE, SIGMA, RHO, BINS, LAYERS, M = 0.3, 0.85, 3.2, 32, 40, 1024


def repulsion_spec() -> ModelSpec:
    d = np.linspace(0.0, RHO, BINS)
    kernel = -AMPLITUDE * np.exp(-(d**2) / (2 * SIGMA**2))
    kernel[-1] = 0.0  # continuous at the radius
    layers = [Layer(subspaces=[0b11], radius=[RHO], kernels=kernel[None, :]) for _ in range(LAYERS)]
    return ModelSpec(
        dims=2,
        n_points=M,
        layers=layers,
        name="repulsion-2d",
        description=(
            "Hand-designed 2-D blue noise: 40 layers of a fixed Gaussian repulsion "
            "kernel (A=0.3, sigma=0.85, rho=3.2 mean spacings). Not trained."
        ),
        metadata={"dpc.source": "models/make_repulsion_2d.py", "dpc.trained": "no"},
    )


if __name__ == "__main__":
    out = Path(__file__).with_name("repulsion-2d.onnx")
    write_model(repulsion_spec(), out)
    print(f"wrote {out} ({out.stat().st_size} bytes)")
