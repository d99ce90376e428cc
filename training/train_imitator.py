"""Train the imitator I(X, g) (paper 5.1-5.2): l1 * L_imitation + l2 * L_sens + L_GAN, critic with gradient penalty."""

from __future__ import annotations

import dataclasses
import sys

import torch

from vto_core.dataset import DatasetReader, DatasetUnion, open_datasets

from .config import ImitatorConfig, config_dict, data_record, with_epochs
from .data import RenderDataset, held_out_folders, held_out_text, make_loader, per_process_batch, split, training_batches
from .distributed import Processes, processes
from .losses import PerceptualDistance, critic_loss, generator_adversarial_loss, sensitivity_loss, weighted_total
from .networks import Critic, Imitator
from .run import RunFolder, optimise


def imitator_losses(imitator: Imitator, critic: Critic, critic_opt, perceptual: PerceptualDistance, batch: dict,
                    config: ImitatorConfig) -> tuple[dict[str, torch.Tensor], torch.Tensor]:
    """One step's critic update(s), then the imitator's loss terms and total (see losses.weighted_total).

    The log has each term unweighted and `<term>_weighted`; `critic` is the critic's own loss (not in the total).
    """
    device = config.device
    source, render, g = (batch[k].to(device) for k in ("source", "render", "g"))
    extra = {}
    if config.use_gan:
        for _ in range(config.critic_steps):
            with torch.no_grad():
                fake = imitator(source, g)
            loss_d = critic_loss(critic, render, fake, config.lambda_gp)
            critic_opt.zero_grad(set_to_none=True)
            loss_d.backward()
            critic_opt.step()
        extra["critic"] = loss_d.detach()
    terms = {}
    if config.use_sensitivity:  # one imitator pass for I(X, g) and every I(X, g'_j)
        moved_render, moved_g = batch["moved_render"].to(device), batch["moved_g"].to(device)
        fake, fake_moved = imitate_with_moved(imitator, source, g, moved_g)
        terms["imitation"] = (perceptual(fake, render), config.lambda_imitation)
        terms["sensitivity"] = (sensitivity_loss(render, moved_render, fake, fake_moved), config.lambda_sens)
    else:
        fake = imitator(source, g)
        terms["imitation"] = (perceptual(fake, render), config.lambda_imitation)
    if config.use_gan:
        terms["adversarial"] = (generator_adversarial_loss(critic, fake), 1.0)
    losses, total = weighted_total(terms)
    return {**losses, **extra}, total


def imitate_with_moved(imitator: Imitator, source: torch.Tensor, g: torch.Tensor, moved_g: torch.Tensor):
    """I(X, g) (B, 3, H, W) and I(X, g'_j) for every j (B, m, 3, H, W) in one batched pass; moved_g: (B, m, m)."""
    batch, m = moved_g.shape[:2]
    repeated = source.unsqueeze(1).expand(-1, m, -1, -1, -1).reshape(batch * m, *source.shape[1:])
    images = imitator(torch.cat([source, repeated]), torch.cat([g, moved_g.reshape(batch * m, -1)]))
    return images[:batch], images[batch:].reshape(batch, m, *source.shape[1:])


@torch.no_grad()
def evaluate(imitator: Imitator, loader, perceptual: PerceptualDistance, device: str) -> dict[str, float]:
    """Held-out imitation distance and L1 of I(X, g) against R(X, g); with sensitivity renders, the sensitivity loss."""
    imitator.eval()
    sums, count = {}, 0
    for batch in loader:
        source, render, g = (batch[k].to(device) for k in ("source", "render", "g"))
        if "moved_g" in batch:
            fake, fake_moved = imitate_with_moved(imitator, source, g, batch["moved_g"].to(device))
            values = {"val_sensitivity": sensitivity_loss(render, batch["moved_render"].to(device), fake, fake_moved)}
        else:
            fake, values = imitator(source, g), {}
        values.update(val_imitation=perceptual(fake, render), val_l1=(fake - render).abs().mean())
        for name, value in values.items():
            sums[name] = sums.get(name, 0.0) + float(value) * len(g)
        count += len(g)
    imitator.train()
    return {name: value / count for name, value in sums.items()}


def train_imitator(data: str | list[str], out: str, config: ImitatorConfig) -> RunFolder:
    """Train (or resume) an imitator run in `out` on the dataset folder `data`.

    Under torchrun every process calls this (see training.distributed); rank 0 writes the run folder.
    """
    reader = open_datasets(data)  # before the run folder exists: a bad --data leaves nothing behind
    with processes(config.device) as procs:
        return _train_imitator(reader, data, out, config, procs)


def _train_imitator(reader: DatasetReader | DatasetUnion, data: str | list[str], out: str, config: ImitatorConfig,
                    procs: Processes) -> RunFolder:
    # 1. Data, resolved config, run folder.
    device = procs.device
    train_positions, val_positions = split(reader, config.val_fraction, config.val_split == "each")
    config = with_epochs(config, len(train_positions))
    train_set = RenderDataset(reader, train_positions, need_sensitivity=config.use_sensitivity)
    run = RunFolder(out)
    if procs.is_main:
        held = held_out_folders(reader, val_positions)
        print(held_out_text(held), file=sys.stderr)
        run.save_config({**config_dict(config), "kind": "imitator", "data": data_record(data),
                         "spec": reader.spec.to_dict(), "held_out": held})
    procs.barrier()
    runtime = dataclasses.replace(config, device=device)  # this process's device (cuda:LOCAL_RANK under torchrun)
    torch.manual_seed(config.seed)
    val_loader = None
    if val_positions and procs.is_main:
        held_out = RenderDataset(reader, val_positions, need_sensitivity=bool(reader.manifest["sensitivity"]))
        val_loader = make_loader(held_out, config.batch_size, 0, shuffle=False)

    # 2. Networks, optimisers, perceptual distance; resume (weights, optimisers and the data order).
    imitator = Imitator(reader.spec.size, config.width, config.n_down, config.n_res).to(device)
    critic = Critic(config.critic_width, config.critic_layers).to(device)
    adam = dict(lr=config.lr, betas=(config.beta1, config.beta2))
    imitator_opt = torch.optim.Adam(imitator.parameters(), **adam)
    critic_opt = torch.optim.Adam(critic.parameters(), **adam)
    perceptual = PerceptualDistance(config.perceptual, config.vgg_weights or None).to(device)
    global_batch = per_process_batch(config.batch_size, len(train_set), procs.world_size) * procs.world_size
    step, position = 0, 0
    checkpoint = run.load_checkpoint()
    if checkpoint is not None:
        imitator.load_state_dict(checkpoint["model"])
        imitator_opt.load_state_dict(checkpoint["optimizer"])
        critic.load_state_dict(checkpoint["critic"])
        critic_opt.load_state_dict(checkpoint["critic_optimizer"])
        step = checkpoint["step"]
        position = checkpoint.get("data_position", step * global_batch)
        if procs.is_main:
            run.truncate_log(step)

    def save(at_step: int) -> None:
        run.save_checkpoint({
            "kind": "imitator", "step": at_step, "model": imitator.state_dict(), "model_args": imitator.model_args,
            "optimizer": imitator_opt.state_dict(), "critic": critic.state_dict(), "critic_args": critic.model_args,
            "critic_optimizer": critic_opt.state_dict(), "config": config_dict(config), "spec": reader.spec.to_dict(),
            "perceptual": perceptual.kind, "image_size": list(train_set[0]["render"].shape[1:]),
            "data_position": position + (at_step - step) * global_batch,  # the sampler's state: samples consumed
        })

    def validate() -> dict[str, float]:
        return evaluate(imitator, val_loader, perceptual, device) if val_loader is not None else {}

    # 3. Loop: critic update(s), then the imitator on imitation + sensitivity + adversarial terms;
    #    log, validate and checkpoint as configured.
    batches = training_batches(train_set, config.batch_size, config.seed, position, config.num_workers,
                               procs.rank, procs.world_size)
    model, critic_model = procs.wrap(imitator), procs.wrap(critic)
    optimise(run, config, step, batches,
             lambda batch: imitator_losses(model, critic_model, critic_opt, perceptual, batch, runtime),
             imitator_opt, validate, save, procs, scheduled=(critic_opt,))

    # 4. Loss plot.
    if procs.is_main:
        run.plot(f"imitator ({reader.spec.renderer}, {reader.spec.size} parameters)")
    return run
