"""The machinery every stage shares: the process group under torchrun (:func:`_dist`,
:func:`_wrap`), the run folder (:class:`Run`: logs, checkpoints, resume) and the step loop
(:func:`_loop`: Adam, cosine learning rate, periodic logs and checkpoints)."""
from __future__ import annotations

import math
import os
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from viewer.errors import InputError

from .config import TrainConfig

# ---- distributed ---------------------------------------------------------------------------------

def _dist() -> tuple[int, int]:
    """(rank, world size); initialises the process group under torchrun."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world > 1 and not torch.distributed.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        torch.distributed.init_process_group(backend=backend)
    if world > 1:
        return torch.distributed.get_rank(), world
    return 0, 1


def _wrap(model):
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        return torch.nn.parallel.DistributedDataParallel(model)
    return model


def _close_dist() -> None:
    """Tear down the process group :func:`_dist` started, if any."""
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        torch.distributed.destroy_process_group()


# ---- checkpoints and logs ------------------------------------------------------------------------

class Run:
    def __init__(self, cfg: TrainConfig, rank: int, quiet: bool = False):
        self.cfg = cfg
        self.rank = rank
        self.quiet = quiet
        self.out = Path(cfg.out)
        if rank == 0:
            self.out.mkdir(parents=True, exist_ok=True)

    def log(self, msg: str) -> None:
        if self.rank != 0:
            return
        line = f"[{time.strftime('%H:%M:%S')}] {msg}"
        if not self.quiet:
            print(line, flush=True)
        with open(self.out / "train.log", "a") as f:
            f.write(line + "\n")

    def save(self, stage: str, model, opt, step: int, losses: list) -> None:
        if self.rank != 0:
            return
        path = self.out / f"{stage}.pt"
        tmp = path.with_suffix(".pt.tmp")
        torch.save({"model": model.state_dict(), "opt": opt.state_dict(), "step": step,
                    "losses": losses, "config": asdict(self.cfg),
                    "rng": torch.get_rng_state()}, tmp)
        os.replace(tmp, path)

    def load(self, stage: str, model, opt) -> tuple[int, list]:
        path = self.out / f"{stage}.pt"
        if not path.is_file():
            return 0, []
        try:
            ck = torch.load(path, map_location="cpu", weights_only=True)
            model.load_state_dict(ck["model"])
            if opt is not None:
                opt.load_state_dict(ck["opt"])
            torch.set_rng_state(ck["rng"])
        except Exception as exc:  # noqa: BLE001 - any unreadable checkpoint is a user error
            raise InputError(f"cannot resume from this checkpoint ({type(exc).__name__}: "
                             f"{str(exc).splitlines()[0] if str(exc) else ''}); delete it to "
                             f"restart the stage", where=path) from None
        return int(ck["step"]), list(ck["losses"])


# ---- the step loop -------------------------------------------------------------------------------

def _loop(run: Run, stage: str, model, steps: int, lr: float, step_fn) -> list[float]:
    """Adam over ``steps`` steps of ``step_fn(ddp_model, step) -> loss``, with resume."""
    opt = torch.optim.Adam(model.parameters(), lr=lr, betas=(0.9, 0.999))
    start, losses = run.load(stage, model, opt)
    if start >= steps:
        run.log(f"{stage}: finished checkpoint ({start} steps), loaded")
        return losses
    if start:
        run.log(f"{stage}: resuming at step {start}/{steps}")
    ddp = _wrap(model)
    sched_lr = lambda s: lr * 0.5 * (1.0 + math.cos(math.pi * s / steps))  # noqa: E731
    t0 = time.time()
    bar = tqdm(range(start, steps), desc=stage, unit="step", disable=run.rank != 0 or run.quiet,
               file=sys.stderr)
    for step in bar:
        for g in opt.param_groups:
            g["lr"] = sched_lr(step)
        loss = step_fn(ddp, step)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        losses.append(loss.item())
        if (step + 1) % run.cfg.log_every == 0 or step + 1 == steps:
            recent = float(np.mean(losses[-run.cfg.log_every:]))
            run.log(f"{stage} step {step + 1}/{steps} loss {recent:.5f} ({time.time() - t0:.1f} s)")
        if (step + 1) % run.cfg.checkpoint_every == 0 or step + 1 == steps:
            run.save(stage, model, opt, step + 1, losses)
    return losses
