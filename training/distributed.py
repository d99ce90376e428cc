"""Training past one process: torchrun's environment -> a process group, DDP wrapping, rank-0 duties.

One machine, N processes (gloo on CPU, nccl on CUDA, each process on cuda:LOCAL_RANK):

    torchrun --nproc_per_node N -m vto_core.cli train encoder --data DATA --out RUN [--set KEY=VALUE ...]
    torchrun --nproc_per_node N -m vto_core.cli train imitator --data DATA --out RUN --device cuda

Several machines: the same command with torchrun's --nnodes / --node-rank / --rdzv-endpoint (or srun under SLURM).
`batch_size` stays the global batch, split evenly over the processes; each process reads its DistributedSampler
shard. Rank 0 alone writes config.json, checkpoints, losses.jsonl and the plot; every rank reads the checkpoint
when a run resumes. Without torchrun (WORLD_SIZE unset or 1) everything runs in this process, as before.
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass

import torch
from torch import distributed as dist

from vto_core.errors import VtoError


@dataclass(frozen=True)
class Processes:
    """Where this process stands in the job: rank, world size, and the device it trains on."""

    rank: int = 0
    world_size: int = 1
    device: str = "cpu"

    @property
    def is_main(self) -> bool:
        """Whether this process writes the run folder."""
        return self.rank == 0

    def wrap(self, module: torch.nn.Module) -> torch.nn.Module:
        """The module wrapped in DistributedDataParallel when there are several processes (else itself)."""
        if self.world_size == 1:
            return module
        from torch.nn.parallel import DistributedDataParallel

        ids = [torch.device(self.device).index] if self.device.startswith("cuda") else None
        return DistributedDataParallel(module, device_ids=ids)

    def mean(self, values: dict[str, torch.Tensor]) -> dict[str, float]:
        """Scalar tensors -> floats averaged over the processes (every rank gets the same numbers)."""
        if self.world_size == 1 or not values:
            return {name: float(value) for name, value in values.items()}
        stacked = torch.stack([value.detach().reshape(()).double() for value in values.values()]).to(self.device)
        dist.all_reduce(stacked)
        return dict(zip(values, (stacked / self.world_size).tolist()))

    def barrier(self) -> None:
        """Wait for every process (no-op alone)."""
        if self.world_size > 1:
            dist.barrier()


@contextlib.contextmanager
def processes(device: str):
    """Join the torchrun job this process belongs to (if any) for the duration of a run; yields Processes."""
    world_size = int(os.environ.get("WORLD_SIZE", "1"))
    if world_size == 1:
        yield Processes(device=device)
        return
    if not dist.is_available():
        raise VtoError("WORLD_SIZE > 1 but this torch build has no torch.distributed")
    rank, local_rank = int(os.environ["RANK"]), int(os.environ.get("LOCAL_RANK", "0"))
    cuda = device.startswith("cuda")
    if cuda:
        if local_rank >= torch.cuda.device_count():
            raise VtoError(f"process {rank} wants cuda:{local_rank} but torch sees {torch.cuda.device_count()} GPUs")
        device = f"cuda:{local_rank}"
        torch.cuda.set_device(device)
    joined_here = not dist.is_initialized()
    if joined_here:
        dist.init_process_group("nccl" if cuda else "gloo")
    try:
        yield Processes(rank, world_size, device)
    finally:
        if joined_here:
            dist.destroy_process_group()
