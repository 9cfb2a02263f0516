"""Landmarks from video on the CPU: MediaPipe's vendored models (media/assets/mediapipe) run with
ai-edge-litert, connected by signcast's own Holistic graph (detection, rotated ROIs, tracking)."""
