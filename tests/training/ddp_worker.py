"""Run by test_distributed under torchrun: train a tiny imitator, then save this rank's trained and initial weights.

    python -m torch.distributed.run --standalone --nproc_per_node 2 tests/training/ddp_worker.py DATA OUT KEY=VALUE...
"""

import os
import sys

import torch

import training.train_imitator as trainer
from training.config import ImitatorConfig, resolve_config

made = []


class _Kept:
    """Mixin: remember each network built in this process, and its initial weights."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.initial = {name: value.clone() for name, value in self.state_dict().items()}
        made.append(self)


class KeptImitator(_Kept, trainer.Imitator):
    """The real Imitator, remembered."""


class KeptCritic(_Kept, trainer.Critic):
    """The real Critic, remembered."""


if __name__ == "__main__":
    data, out, *settings = sys.argv[1:]
    trainer.Imitator, trainer.Critic = KeptImitator, KeptCritic
    trainer.train_imitator(data, os.path.join(out, "run"), resolve_config(ImitatorConfig, None, settings))
    imitator, critic = made
    torch.save({"imitator": imitator.state_dict(), "imitator_initial": imitator.initial,
                "critic": critic.state_dict(), "critic_initial": critic.initial},
               os.path.join(out, f"rank{os.environ['RANK']}.pt"))
