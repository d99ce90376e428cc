"""Train the inverse-graphics encoder E (paper 5.3): L_graphics + l3 * L_rendering through the frozen imitator."""

from __future__ import annotations

import dataclasses
import sys

import torch

from vto_core.dataset import DatasetReader, DatasetUnion, open_datasets
from vto_core.errors import VtoError
from vto_core.products import get_product
from vto_core.specs import RendererSpec

from .config import EncoderConfig, config_dict, data_record, with_epochs
from .data import (RenderDataset, encoder_views, held_out_folders, held_out_text, make_loader, per_process_batch, split,
                   training_batches)
from .distributed import Processes, processes
from .losses import (PerceptualDistance, colour_loss, graphics_errors, graphics_loss, parameter_difference,
                     parameter_weights, weighted_total)
from .networks import Encoder, build
from .run import RunFolder, optimise


def load_frozen_imitator(run_path: str, spec: RendererSpec, device: str,
                         image_size: list[int] | None = None) -> torch.nn.Module:
    """The imitator of a finished run, frozen; refused if made for another renderer, spec or image size."""
    checkpoint = RunFolder(run_path).load_checkpoint(required=True)
    if checkpoint.get("kind") != "imitator":
        raise VtoError(f"{run_path} is a {checkpoint.get('kind')} run, not an imitator run")
    theirs = RendererSpec.from_dict(checkpoint["spec"])
    if theirs.renderer != spec.renderer:
        raise VtoError(f"the imitator in {run_path} imitates the {theirs.renderer} renderer, not {spec.renderer}")
    if not theirs.same_as(spec):
        raise VtoError(f"the imitator in {run_path} models [{', '.join(theirs.modelled)}], this dataset "
                       f"[{', '.join(spec.modelled)}]: another parameter spec")
    if image_size is not None and list(checkpoint.get("image_size", image_size)) != list(image_size):
        raise VtoError(f"the imitator in {run_path} was trained on {checkpoint['image_size']} images, this dataset "
                       f"has {list(image_size)}")
    imitator = build("imitator", checkpoint["model_args"]).to(device)
    imitator.load_state_dict(checkpoint["model"])
    imitator.eval()
    for parameter in imitator.parameters():
        parameter.requires_grad_(False)
    return imitator


def new_encoder(spec: RendererSpec, config: EncoderConfig) -> Encoder:
    """The untrained encoder `config` describes for `spec`'s parameters."""
    return Encoder(spec.size, config.width, config.n_layers, pool_size=config.pool_size, blocks=config.blocks,
                   batch_norm=int(config.batch_norm), input_filter=config.input_filter)


def encoder_losses(encoder: Encoder, imitator, perceptual, batch: dict, config: EncoderConfig, wraps=None,
                   weights=None, colour_net=None, *, error):
    """g_hat = E(R(X, g)); graphics loss on g, rendering loss on I(X, g_hat) vs R(X, g), colour loss through the
    colour imitator (colour_net) where given: (log dict, total). error: the graphics loss's, as graphics_errors gives it
    from config.graphics_error and config.absolute_parameters.

    The log holds each term unweighted and `<term>_weighted` (as it enters the total), and the total.
    """
    device = config.device
    render, g = batch["render"].to(device), batch["g"].to(device)
    g_hat = encoder(render)
    terms = {}  # name -> (unweighted value, weight)
    if config.loss in ("graphics", "both"):
        terms["graphics"] = (graphics_loss(g, g_hat, wraps, error, weights), 1.0)
    if config.loss in ("rendering", "both"):
        terms["rendering"] = (perceptual(imitator(batch["source"].to(device), g_hat), render), config.lambda_rendering)
    if colour_net is not None:
        terms["colour"] = (colour_loss(colour_net, g, g_hat), config.lambda_colour)
    return weighted_total(terms)


@torch.no_grad()
def parameter_error(encoder: Encoder, loader, device: str, wraps=None) -> float:
    """Held-out mean squared error of the normalised parameters (wrapping ones on the circle)."""
    encoder.eval()
    total, count = 0.0, 0
    for batch in loader:
        g = batch["g"].to(device)
        total += float(parameter_difference(g, encoder(batch["render"].to(device)), wraps).square().mean()) * len(g)
        count += len(g)
    encoder.train()
    return total / count


def train_encoder(data: str | list[str], imitator_run: str | None, out: str, config: EncoderConfig) -> RunFolder:
    """Train (or resume) an encoder run in `out`; the imitator is needed unless loss == 'graphics'.

    Under torchrun every process calls this (see training.distributed); rank 0 writes the run folder.
    """
    reader = open_datasets(data)  # bad inputs fail before a run folder exists
    if config.loss in ("rendering", "both") and not imitator_run:
        raise VtoError("the rendering loss needs --imitator RUN (or --set loss=graphics)")
    if config.mouth_views and not get_product(reader.spec.renderer).mouth_views:
        raise VtoError(f"mouth_views paints teeth over lips: a {reader.spec.renderer} dataset has none")
    with processes(config.device) as procs:
        return _train_encoder(reader, data, imitator_run, out, config, procs)


def _train_encoder(reader: DatasetReader | DatasetUnion, data: str | list[str], imitator_run: str | None, out: str,
                   config: EncoderConfig, procs: Processes) -> RunFolder:
    # 1. Data and the frozen imitator (the rendering loss) first: bad inputs leave no run folder behind.
    device = procs.device
    use_rendering = config.loss in ("rendering", "both")
    res = reader.manifest["res"]
    image_size = [res, res] if isinstance(res, int) else list(res[::-1])  # (H, W); a user scene records (W, H)
    wraps = [p.wraps for p in reader.spec.modelled_params]
    names = [p.name for p in reader.spec.modelled_params]
    weights = parameter_weights(config.parameter_weights, names)
    error = graphics_errors(config.graphics_error, config.absolute_parameters, names)
    imitator = load_frozen_imitator(imitator_run, reader.spec, device, image_size) if use_rendering else None
    train_positions, val_positions = split(reader, config.val_fraction, config.val_split == "each")
    config = with_epochs(config, len(train_positions))
    initial = None
    if config.init:  # fine-tuning: refused here, before a run folder exists, for another spec or network
        from .export import onnx_encoder_weights

        initial = onnx_encoder_weights(config.init, new_encoder(reader.spec, config), reader.spec)
    colour_net = None
    if config.lambda_colour > 0:
        from .export import onnx_colour_net

        if not config.colour_imitator:
            raise VtoError("lambda_colour > 0 needs colour_imitator=FILE.onnx (vto train colour's output)")
        colour_net = onnx_colour_net(config.colour_imitator, reader.spec).to(device)
    run = RunFolder(out)
    if procs.is_main:
        held = held_out_folders(reader, val_positions)
        print(held_out_text(held), file=sys.stderr)
        run.save_config({**config_dict(config), "kind": "encoder", "data": data_record(data), "imitator": imitator_run,
                         "spec": reader.spec.to_dict(), "held_out": held})
    procs.barrier()
    runtime = dataclasses.replace(config, device=device)  # this process's device (cuda:LOCAL_RANK under torchrun)
    torch.manual_seed(config.seed)
    train_set = RenderDataset(reader, train_positions, need_source=use_rendering)
    val_loader = (make_loader(RenderDataset(reader, val_positions, need_source=False), config.batch_size, 0,
                              shuffle=False)
                  if val_positions and procs.is_main else None)

    # 2. Encoder, perceptual distance, optimiser; resume (weights, optimiser and the data order).
    perceptual = PerceptualDistance(config.perceptual, config.vgg_weights or None).to(device) if use_rendering else None
    encoder = new_encoder(reader.spec, config).to(device)
    optimiser = torch.optim.Adam(encoder.parameters(), lr=config.lr, betas=(config.beta1, config.beta2))
    global_batch = per_process_batch(config.batch_size, len(train_set), procs.world_size) * procs.world_size
    step, position = 0, 0
    checkpoint = run.load_checkpoint()
    if checkpoint is None and initial is not None:
        encoder.load_state_dict(initial)
    if checkpoint is not None:
        encoder.load_state_dict(checkpoint["model"])
        optimiser.load_state_dict(checkpoint["optimizer"])
        step = checkpoint["step"]
        position = checkpoint.get("data_position", step * global_batch)
        if procs.is_main:
            run.truncate_log(step)

    def save(at_step: int) -> None:
        run.save_checkpoint({
            "kind": "encoder", "step": at_step, "model": encoder.state_dict(), "model_args": encoder.model_args,
            "optimizer": optimiser.state_dict(), "config": config_dict(config), "spec": reader.spec.to_dict(),
            "image_size": image_size, "imitator": imitator_run,
            "data_position": position + (at_step - step) * global_batch,  # the sampler's state: samples consumed
        })

    def validate() -> dict[str, float]:
        if val_loader is None:
            return {}
        return {"val_param_mse": parameter_error(encoder, val_loader, device, wraps)}

    # 3. Loop: g_hat = E(R(X, g)); graphics loss on g, rendering loss on I(X, g_hat) vs R(X, g).
    batches = training_batches(train_set, config.batch_size, config.seed, position, config.num_workers,
                               procs.rank, procs.world_size)
    model = procs.wrap(encoder)
    optimise(run, config, step, batches,
             lambda batch: encoder_losses(model, imitator, perceptual, encoder_views(batch, config),
                                          runtime, wraps, weights, colour_net, error=error),
             optimiser, validate, save, procs)

    # 4. Loss plot.
    if procs.is_main:
        run.plot(f"encoder ({reader.spec.renderer}, loss: {config.loss})")
    return run
