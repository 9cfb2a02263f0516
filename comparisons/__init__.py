"""The shared encoder layer: pure functions on data, no file I/O and no progress bars, in six rooms by job.

  video/      natural and rendered video: objects (NSV, NSV2O, NSV3O), binary shape coding (CAE), the
              MPEG-4 padding, today's video codecs through PyAV, image quality (PSNR, SSIM)
  params/     MPEG-4 animation parameters: FBA (BAPs, FAPs), BBA (bones), their tables, the one compiled
              arithmetic coder every stream uses, bit I/O, key frames, the .bap/.fap text layout
  lab/        the seed-002 motion coders (waveform, model-based, vector quantisation, wavelet-cx) and motion
              statistics
  transport/  live units of each stream, RTP payloads, MPEG-2 TS, loss models, live video coding
  judging/    landmark metrics, intelligibility and message fidelity, letter recognition, matching a solution
              at the rate where it stays readable, the source's criteria scores
  reports/    records (the typed result of every measured point) and the HTML reports made from them

Dependencies inside: judging and reports read every other room; transport reads video and params; lab reads
params (the BAP layout); nothing reads reports except the study layer.
"""
