"""Live delivery over real sockets: a paced sender, a lossy UDP relay and a receiver that decodes, conceals and
renders as packets arrive (issue 16; DESIGN.md "Delivery and scale"). The studies and commands in
pipeline/studies/live.py and pipeline/commands/{send,receive,live}.py run these pieces; the packet formats and
loss models they use are the pure functions of comparisons/ (rtp, loss_models, fba_units, live_video)."""
