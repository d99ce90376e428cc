"""Train the imitator I(X, g) (paper 5.1-5.2): l1 * L_imitation + l2 * L_sens + L_GAN, critic with gradient penalty."""

from __future__ import annotations

import torch

from vto_core.dataset import DatasetReader

from .config import ImitatorConfig, config_dict
from .data import RenderDataset, make_loader, split, training_batches
from .losses import PerceptualDistance, critic_loss, generator_adversarial_loss, sensitivity_loss
from .networks import Critic, Imitator
from .run import RunFolder, optimise


def imitate_moved(imitator: Imitator, source: torch.Tensor, moved_g: torch.Tensor) -> torch.Tensor:
    """I(X, g'_j) for every j: source (B, 3, H, W), moved_g (B, m, m) -> (B, m, 3, H, W)."""
    batch, m = moved_g.shape[:2]
    repeated = source.unsqueeze(1).expand(-1, m, -1, -1, -1).reshape(batch * m, *source.shape[1:])
    return imitator(repeated, moved_g.reshape(batch * m, -1)).reshape(batch, m, *source.shape[1:])


def imitator_losses(imitator: Imitator, critic: Critic, critic_opt, perceptual: PerceptualDistance, batch: dict,
                    config: ImitatorConfig) -> tuple[dict[str, torch.Tensor], torch.Tensor]:
    """One step's critic update(s), then the imitator's loss terms (detached, for the log) and its total."""
    device = config.device
    source, render, g = (batch[k].to(device) for k in ("source", "render", "g"))
    losses = {}
    if config.use_gan:
        for _ in range(config.critic_steps):
            with torch.no_grad():
                fake = imitator(source, g)
            loss_d = critic_loss(critic, render, fake, config.lambda_gp)
            critic_opt.zero_grad(set_to_none=True)
            loss_d.backward()
            critic_opt.step()
        losses["critic"] = loss_d.detach()
    fake = imitator(source, g)
    loss_imitation = perceptual(fake, render)
    total = config.lambda_imitation * loss_imitation
    losses["imitation"] = loss_imitation.detach()
    if config.use_sensitivity:
        moved_render, moved_g = batch["moved_render"].to(device), batch["moved_g"].to(device)
        loss_sens = sensitivity_loss(render, moved_render, fake, imitate_moved(imitator, source, moved_g))
        total = total + config.lambda_sens * loss_sens
        losses["sensitivity"] = loss_sens.detach()
    if config.use_gan:
        loss_gan = generator_adversarial_loss(critic, fake)
        total = total + loss_gan
        losses["adversarial"] = loss_gan.detach()
    losses["total"] = total.detach()
    return losses, total


@torch.no_grad()
def evaluate(imitator: Imitator, loader, perceptual: PerceptualDistance, device: str) -> dict[str, float]:
    """Held-out imitation distance and L1 of I(X, g) against R(X, g)."""
    imitator.eval()
    total, l1, count = 0.0, 0.0, 0
    for batch in loader:
        source, render, g = (batch[k].to(device) for k in ("source", "render", "g"))
        fake = imitator(source, g)
        total += float(perceptual(fake, render)) * len(g)
        l1 += float((fake - render).abs().mean()) * len(g)
        count += len(g)
    imitator.train()
    return {"val_imitation": total / count, "val_l1": l1 / count}


def train_imitator(data: str, out: str, config: ImitatorConfig) -> RunFolder:
    """Train (or resume) an imitator run in `out` on the dataset folder `data`."""
    # 1. Run folder, resolved config, data.
    reader = DatasetReader(data)  # before the run folder exists: a bad --data leaves nothing behind
    run = RunFolder(out)
    run.save_config({**config_dict(config), "kind": "imitator", "data": str(data), "spec": reader.spec.to_dict()})
    torch.manual_seed(config.seed)
    device = config.device
    train_positions, val_positions = split(reader, config.val_fraction)
    train_set = RenderDataset(reader, train_positions, need_sensitivity=config.use_sensitivity)
    val_loader = make_loader(RenderDataset(reader, val_positions), config.batch_size, 0, shuffle=False) if val_positions else None

    # 2. Networks, optimisers, perceptual distance; resume from the last checkpoint.
    imitator = Imitator(reader.spec.size, config.width, config.n_down, config.n_res).to(device)
    critic = Critic(config.critic_width, config.critic_layers).to(device)
    adam = dict(lr=config.lr, betas=(config.beta1, config.beta2))
    imitator_opt = torch.optim.Adam(imitator.parameters(), **adam)
    critic_opt = torch.optim.Adam(critic.parameters(), **adam)
    perceptual = PerceptualDistance(config.perceptual, config.vgg_weights or None).to(device)
    step = 0
    checkpoint = run.load_checkpoint()
    if checkpoint is not None:
        imitator.load_state_dict(checkpoint["model"])
        imitator_opt.load_state_dict(checkpoint["optimizer"])
        critic.load_state_dict(checkpoint["critic"])
        critic_opt.load_state_dict(checkpoint["critic_optimizer"])
        step = checkpoint["step"]
        run.truncate_log(step)

    def save(at_step: int) -> None:
        run.save_checkpoint({
            "kind": "imitator", "step": at_step, "model": imitator.state_dict(), "model_args": imitator.model_args,
            "optimizer": imitator_opt.state_dict(), "critic": critic.state_dict(), "critic_args": critic.model_args,
            "critic_optimizer": critic_opt.state_dict(), "config": config_dict(config), "spec": reader.spec.to_dict(),
            "perceptual": perceptual.kind, "image_size": list(train_set[0]["render"].shape[1:]),
        })

    def validate() -> dict[str, float]:
        return evaluate(imitator, val_loader, perceptual, device) if val_loader is not None else {}

    # 3. Loop: critic update(s), then the imitator on imitation + sensitivity + adversarial terms;
    #    log, validate and checkpoint as configured.
    batches = training_batches(train_set, config.batch_size, config.seed, step, config.num_workers)
    optimise(run, config, step, batches,
             lambda batch: imitator_losses(imitator, critic, critic_opt, perceptual, batch, config),
             imitator_opt, validate, save)

    # 4. Loss plot.
    run.plot(f"imitator ({reader.spec.renderer}, {reader.spec.size} parameters)")
    return run
