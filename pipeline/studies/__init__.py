"""The study layer: every study loads its data, loops over its points, renders, and writes its files here and
only here. Each module takes one settings dataclass and returns records:

video     natural clip (NSV, NSV2O, NSV3O, NSV3O+C) or rendered signer (NSV, SSV) as video objects
compare   one signing through the six solutions (a video, a fingerspelled word or a .pose), judged by landmarks
          extracted from what each viewer sees, matched on intelligibility; report, side by side
pose      landmarks of a signer's video (signcast's Holistic graph) written as .pose
params    each fingerspelled letter with each parameter codec at each Q (seed 000 Tables 2.1, 3.1, 3.2)
lab       seed-002 coders and FBA/BBA on whole alphabets (seed 002 ch. 9 charts)
analyze   motion statistics of whole alphabets per DOF and joint group (seed 002 ch. 5)
render    the avatar fingerspelling a word (or performing a .pose) to a lossless video and part labels
motion    the avatar fingerspelling a word (or performing a .pose), written as BVH

`comparisons/` holds the pure pieces the studies are made of (codecs, metrics, tables and charts of records);
`pipeline/commands/` parses arguments into the settings and calls `run`.
"""
