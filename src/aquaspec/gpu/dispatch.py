"""Compute pipelines and recording their dispatches into a command encoder."""

from __future__ import annotations


def compute_pipeline(device, layout, code: str, label: str, entry_point: str = "main"):
    """A compute pipeline of the WGSL ``code`` with the one bind-group ``layout``."""
    module = device.create_shader_module(label=label, code=code)
    return device.create_compute_pipeline(
        label=label, layout=device.create_pipeline_layout(bind_group_layouts=[layout]),
        compute={"module": module, "entry_point": entry_point})


def record_dispatch(encoder, pipeline, bind_group, workgroups, timestamp_writes=None) -> None:
    """Record one compute pass: ``pipeline`` with ``bind_group`` over ``workgroups``.

    ``timestamp_writes`` (optional) brackets the pass for
    :func:`aquaspec.gpu.timing.time_passes`.
    """
    record_dispatches(encoder, [(pipeline, bind_group, workgroups)], timestamp_writes)


def record_dispatches(encoder, dispatches, timestamp_writes=None) -> None:
    """Record ``(pipeline, bind_group, workgroups)`` dispatches in order in one compute pass.

    Each dispatch is its own usage scope (WebGPU), so a dispatch may read what
    the one before wrote. One pass instead of one per dispatch: on lavapipe a
    compute pass of its own cost a small dispatch 40-90 us, in a shared pass
    20-40 us (measured with 21 dispatches of 1-64 workgroups).
    """
    kwargs = {} if timestamp_writes is None else {"timestamp_writes": timestamp_writes}
    cp = encoder.begin_compute_pass(**kwargs)
    for pipeline, bind_group, workgroups in dispatches:
        cp.set_pipeline(pipeline)
        cp.set_bind_group(0, bind_group)
        cp.dispatch_workgroups(*workgroups)
    cp.end()


def submit_pass(device, gpu_pass) -> None:
    """Record ``gpu_pass.encode`` into a new encoder and submit it (does not wait)."""
    enc = device.create_command_encoder()
    gpu_pass.encode(enc)
    device.queue.submit([enc.finish()])
