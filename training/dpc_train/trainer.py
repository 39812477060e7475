"""The training loop: Adam with exponential learning-rate decay over batches of realisations,
tqdm progress, atomic checkpoints, resume, per-seed determinism, loss curve (CSV + PNG), and
guards against divergence: a NaN/inf loss or gradient, an error inside torch (e.g. an overflow
from a huge learning rate), a loss that jumps and stays up, points that collapse. On any of them
the run stops with TrainingDivergedError, and the checkpoint on disk is the last good one (a
checkpoint is only written while the run is healthy)."""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
import time
from pathlib import Path

import torch

from . import losses as L
from .cascade import Cascade
from .config import Config, config_from_dict
from .lossprog import build_loss

CHECKPOINT = "checkpoint.pt"


class TrainingError(RuntimeError):
    """Base class of the trainer's errors."""


class TrainingDivergedError(TrainingError):
    """The run diverged (NaN/inf, an error inside torch, a loss jump, collapsed points)."""


# Temporary files of atomic_write_bytes: ".NAME.<random>.tmp" beside NAME.
_TEMP_PREFIXES = tuple(f".{n}." for n in ("checkpoint.pt", "loss.csv", "loss.png", "config.json", "quality.json"))


def remove_stale_temporaries(run_dir: Path) -> list[Path]:
    """Delete the temporary files a killed run left in run_dir (only ours: .NAME.*.tmp)."""
    gone = []
    if run_dir.is_dir():
        for f in run_dir.iterdir():
            if f.name.endswith(".tmp") and f.name.startswith(_TEMP_PREFIXES) and f.is_file():
                f.unlink()
                gone.append(f)
    return gone


def collapsed(y: torch.Tensor, share: float = 0.1) -> bool:
    """Whether more than `share` of the points of set 0 coincide with another point of it at
    float32 resolution (delta_min = 0 for a large part of the set)."""
    s = y[0].detach().double().cpu()
    q = torch.round(s * (1 << 24)).to(torch.int64)
    distinct = torch.unique(q, dim=0).shape[0]
    return distinct < (1.0 - share) * s.shape[0]


class RunExistsError(TrainingError):
    """The run folder already holds a checkpoint and neither --resume nor --force was given."""


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write data to path so that a crash at any moment leaves either the old or the new file:
    temp file in the same folder, fsync, then os.replace (atomic on POSIX and Windows)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, 0o644)  # mkstemp makes 0600; run artifacts are ordinary files
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def save_checkpoint(path: Path, state: dict) -> None:
    buf = io.BytesIO()
    torch.save(state, buf)
    atomic_write_bytes(path, buf.getvalue())


def load_checkpoint(path: str | Path) -> dict:
    return torch.load(str(path), map_location="cpu", weights_only=False)


def step_generator(seed: int, step: int) -> torch.Generator:
    """The RNG of one step: a pure function of (seed, step), so a resumed run sees exactly the
    inputs the uninterrupted run would have seen."""
    return torch.Generator().manual_seed((seed * 1_000_003 + step) % (1 << 63))


def measure_quality(model: Cascade, loss_fn, cfg: Config, device="cpu") -> dict:
    """Loss on `eval_sets` fresh realisations (seeds disjoint from training), plus for 2-D
    patterns the spectral metrics of docs/architecture.md (E_low, radial peak)."""
    sp = model.spec
    n_sets = max(1, cfg.train.eval_sets)
    g = torch.Generator().manual_seed(0x5EED_0000 + cfg.train.seed)
    with torch.no_grad():
        x = model.input_points(n_sets, g, device=device)
        y = model(x, impl=cfg.train.impl)
        torch.manual_seed(cfg.train.seed)
        q = {"eval_sets": n_sets, "eval_loss": float(loss_fn(y))}
        if sp.dims == 2 and not sp.grid_axes:
            y64 = y.double().cpu()
            q["E_low_nu<0.5"] = float(L.lowband_energy(y64, 0.5))
            q["E_low_nu<0.75"] = float(L.lowband_energy(y64, 0.75))
            rs = L.radspec(y64, nu_max=4.0)
            i = int(rs.argmax())
            q["radial_peak"] = float(rs[i])
            q["radial_peak_nu"] = i / math.sqrt(sp.n_points)
            # minimum distance relative to the maximal packing distance of m discs
            dmax = math.sqrt(2 / (math.sqrt(3) * sp.n_points))
            mins = []
            for s in y64:  # one set at a time: O(m²) memory
                d = s[None] - s[:, None]
                d = d - torch.floor(d + 0.5)
                dist = d.norm(dim=-1) + torch.eye(sp.n_points, dtype=torch.float64) * 10
                mins.append(float(dist.min()))
            q["delta_min"] = sum(mins) / len(mins) / dmax
    return q


class Trainer:
    """One training run in `run_dir` (checkpoint.pt, loss.csv, loss.png, config.json)."""

    def __init__(
        self,
        cfg: Config,
        run_dir: str | Path | None = None,
        resume: bool = False,
        force: bool = False,
        progress: bool = True,
    ):
        self.cfg = cfg
        t = cfg.train
        self.run_dir = Path(run_dir) if run_dir else Path(t.run_dir) / cfg.pattern.name
        self.ckpt_path = self.run_dir / CHECKPOINT
        self.progress = progress
        if t.threads:
            torch.set_num_threads(t.threads)
        if t.device.startswith("cuda") and not torch.cuda.is_available():
            raise TrainingError(f"device {t.device!r} requested but CUDA is not available")
        self.device = torch.device(t.device)
        torch.manual_seed(t.seed)
        self.model = Cascade(cfg.cascade_spec()).to(self.device)
        self.loss_fn, self.loss_source = build_loss(cfg.loss, cfg.pattern.points, cfg.pattern.dims, cfg.base_dir())
        self.opt = torch.optim.Adam(self.model.parameters(), lr=t.lr)
        gamma = (t.lr_final / t.lr) ** (1.0 / t.steps)
        self.sched = torch.optim.lr_scheduler.ExponentialLR(self.opt, gamma=gamma)
        self.step = 0
        self.wall = 0.0
        self.history: list[tuple[int, float, float, float]] = []
        self.removed_temporaries = remove_stale_temporaries(self.run_dir)
        if self.ckpt_path.exists():
            if resume:
                self._restore(load_checkpoint(self.ckpt_path))
            elif not force:
                raise RunExistsError(f"{self.ckpt_path} exists: pass --resume to continue it or --force to start over")
        if not resume:  # a new run: the old run's quality.json would make it look finished
            (self.run_dir / "quality.json").unlink(missing_ok=True)

    # -- checkpoints ------------------------------------------------------------------
    def state(self) -> dict:
        return {
            "format": "dpc-train-checkpoint-1",
            "step": self.step,
            "wall_time": self.wall,
            "config": self.cfg.to_dict(),
            "config_path": self.cfg.source_path,
            "loss_source": self.loss_source,
            "model": self.model.state_dict(),
            "tables": self.model.tables().detach().cpu(),
            "optimizer": self.opt.state_dict(),
            "scheduler": self.sched.state_dict(),
            "history": list(self.history),
            "torch_version": torch.__version__,
        }

    def _restore(self, st: dict) -> None:
        saved = st["config"]
        now = self.cfg.to_dict()
        for sec in ("pattern", "model", "loss"):
            if saved[sec] != now[sec]:
                raise TrainingError(
                    f"cannot resume: [{sec}] differs from the checkpoint's ({saved[sec]} vs {now[sec]})"
                )
        self.model.load_state_dict(st["model"])
        self.opt.load_state_dict(st["optimizer"])
        self.sched.load_state_dict(st["scheduler"])
        self.step, self.wall = int(st["step"]), float(st["wall_time"])
        self.history = [tuple(h) for h in st["history"]]

    def checkpoint(self, final: bool = False) -> None:
        save_checkpoint(self.ckpt_path, self.state())
        # the PNG costs ~0.1 s: redraw it at most once a minute, and at the end
        now = time.monotonic()
        png = final or now - getattr(self, "_last_png", -1e9) > 60
        if png:
            self._last_png = now
        self.write_curve(png=png)

    def write_curve(self, png: bool = True) -> None:
        buf = io.StringIO()
        w = csv.writer(buf)
        w.writerow(["step", "loss", "lr", "wall_s"])
        w.writerows(self.history)
        atomic_write_bytes(self.run_dir / "loss.csv", buf.getvalue().encode())
        if self.history and png:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            fig, ax = plt.subplots(figsize=(6, 3.5))
            steps = [h[0] for h in self.history]
            vals = [h[1] for h in self.history]
            ax.plot(steps, vals, lw=0.6, alpha=0.5, label="loss (one batch)")
            win = max(1, min(25, len(vals) // 5))
            if win > 1:  # batch losses are noisy: show a running mean too
                run = [sum(vals[max(0, i - win + 1) : i + 1]) / (i - max(0, i - win + 1) + 1) for i in range(len(vals))]
                ax.plot(steps, run, lw=1.2, label=f"running mean ({win})")
                ax.legend(fontsize=8)
            ax.set_yscale("log" if min(vals) > 0 else "symlog")  # mask losses go below zero
            ax.set_xlabel("step")
            ax.set_ylabel("loss")
            ax.set_title(self.cfg.pattern.name)
            ax.grid(alpha=0.3)
            fig.tight_layout()
            png = io.BytesIO()
            fig.savefig(png, format="png", dpi=100)
            plt.close(fig)
            atomic_write_bytes(self.run_dir / "loss.png", png.getvalue())

    # -- loop -------------------------------------------------------------------------
    def train_step(self) -> float:
        t = self.cfg.train
        g = step_generator(t.seed, self.step)
        x = self.model.input_points(t.batch, g, device=self.device)
        torch.manual_seed((t.seed * 7_919 + self.step) % (1 << 63))  # Monte Carlo in the loss
        self.opt.zero_grad(set_to_none=True)
        try:
            y = self.model(x, impl=t.impl)
            loss = self.loss_fn(y)
            val = float(loss.detach())
        except RuntimeError as e:  # e.g. an overflow inside torch from kernels blown up by a huge lr
            raise TrainingDivergedError(f"torch failed at step {self.step} ({e}); stopping. {self._last_good()}") from e
        self._last_y = y.detach()
        if not math.isfinite(val):
            raise TrainingDivergedError(
                f"loss is {val} at step {self.step}; stopping. {self._last_good()} Lower [train] "
                f"lr, check the loss program, or resume from the checkpoint."
            )
        try:
            loss.backward()
        except RuntimeError as e:
            raise TrainingDivergedError(
                f"torch failed in the backward pass at step {self.step} ({e}); stopping. {self._last_good()}"
            ) from e
        grad = self.model.theta.grad
        if grad is not None and not torch.isfinite(grad).all():
            raise TrainingDivergedError(
                f"non-finite kernel gradient at step {self.step} (loss {val}); stopping. {self._last_good()}"
            )
        try:
            self.opt.step()
        except RuntimeError as e:
            raise TrainingDivergedError(
                f"the optimiser failed at step {self.step} ({e}); stopping. {self._last_good()}"
            ) from e
        # Checked here, not by the next forward pass: libdpc's C layer (impl "c", the CPU
        # default) refuses non-finite kernels with its own error, torch would overflow somewhere.
        if not torch.isfinite(self.model.theta.detach()).all():
            raise TrainingDivergedError(
                f"the optimiser made kernel values non-finite at step {self.step} (loss {val}); "
                f"stopping. {self._last_good()} Lower [train] lr."
            )
        self.sched.step()
        return val

    # -- divergence ---------------------------------------------------------------------
    def _last_good(self) -> str:
        """Names the checkpoint on disk, which is the last good one (or says there is none)."""
        if self.ckpt_path.exists() and self._last_ckpt is not None:
            return f"The last good checkpoint is {self.ckpt_path} (step {self._last_ckpt})."
        return f"No checkpoint was written (none is at {self.ckpt_path})."

    def _watch(self, val: float) -> str | None:
        """Track the loss; a reason to stop (sustained jump), or None. Sets self._suspect while
        the loss is above the jump threshold, so that no checkpoint is written then."""
        t = self.cfg.train
        self._recent.append(val)
        if len(self._recent) > 10:
            self._recent.pop(0)
        if len(self._recent) == 10:
            mean = sum(self._recent) / 10
            if self._best_mean is None or mean < self._best_mean:
                self._best_mean = mean
        self._suspect = False
        # "factor x the best" for positive losses; in general a rise above the best running mean
        # by (factor - 1) x its magnitude, so that losses below zero (mask losses) work too
        best = self._best_mean
        if t.diverge_factor and best and val > best + (t.diverge_factor - 1.0) * abs(best):
            self._suspect = True
            self._above += 1
            if self._above >= t.diverge_patience:
                return (
                    f"the loss jumped: {val:.4g} at step {self.step}, above {t.diverge_factor:g} x "
                    f"the best running mean {self._best_mean:.4g} for {self._above} steps"
                )
        else:
            self._above = 0
        return None

    def _healthy_for_checkpoint(self) -> str | None:
        """A reason not to write a checkpoint now (the model may be degenerate), or None."""
        if self._suspect:
            return "loss above the jump threshold"
        y = getattr(self, "_last_y", None)
        if y is not None and collapsed(y):
            return "points collapsed"
        return None

    def run(self) -> dict:
        from tqdm import tqdm

        t = self.cfg.train
        self.run_dir.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(self.run_dir / "config.json", json.dumps(self.cfg.to_dict(), indent=2).encode())
        # the checkpoint on disk (a resumed run's), whose step is the last good one
        self._last_ckpt = self.step if self.ckpt_path.exists() else None
        self._recent: list[float] = [h[1] for h in self.history[-10:]]
        self._best_mean = None
        self._above = 0
        self._suspect = False
        pending = False  # a checkpoint is due but was held back while the run looked unhealthy
        bar = tqdm(
            total=t.steps,
            initial=self.step,
            disable=not self.progress,
            unit="step",
            dynamic_ncols=True,
            desc=self.cfg.pattern.name,
        )
        try:
            while self.step < t.steps:
                t0 = time.perf_counter()
                lr = self.opt.param_groups[0]["lr"]
                val = self.train_step()
                self.step += 1
                self.wall += time.perf_counter() - t0
                if self.step % t.log_every == 0 or self.step == t.steps:
                    self.history.append((self.step, val, lr, round(self.wall, 3)))
                bar.update(1)
                bar.set_postfix(loss=f"{val:.4g}", lr=f"{lr:.2g}")
                why = self._watch(val)
                if why:
                    self.write_curve()  # the curve shows what happened; the checkpoint stays
                    raise TrainingDivergedError(f"{why}; stopping. {self._last_good()}")
                if self.step % t.checkpoint_every == 0 or self.step == t.steps or pending:
                    hold = self._healthy_for_checkpoint()
                    if hold == "points collapsed" or (hold and self.step == t.steps):
                        self.write_curve()
                        raise TrainingDivergedError(
                            f"{hold} at step {self.step} (collapsed: more than 10% of a set's "
                            f"points coincide); stopping. {self._last_good()}"
                            if hold == "points collapsed"
                            else f"{hold} at the last step {self.step}; stopping. {self._last_good()}"
                        )
                    pending = bool(hold)
                    if not hold:
                        self.checkpoint(final=self.step == t.steps)
                        self._last_ckpt = self.step
        finally:
            bar.close()
        quality = measure_quality(self.model, self.loss_fn, self.cfg, self.device)
        st = self.state()
        st["quality"] = quality
        save_checkpoint(self.ckpt_path, st)
        atomic_write_bytes(self.run_dir / "quality.json", json.dumps(quality, indent=2).encode())
        return {"run_dir": str(self.run_dir), "steps": self.step, "wall_time": self.wall, "quality": quality}


def cascade_from_checkpoint(st: dict) -> tuple[Cascade, Config]:
    """Rebuild the trained cascade and its config from a checkpoint dict."""
    cfg = config_from_dict(st["config"], st.get("config_path", ""))
    model = Cascade(cfg.cascade_spec(), initialise=False)
    model.load_state_dict(st["model"])
    return model, cfg
