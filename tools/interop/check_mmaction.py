"""Loads an autoact dataset with MMAction2's own datasets and pipelines (mmaction2 1.2.0):

- `PoseDataset` on `skeleton_2d_coco17.pkl` with the data pipeline of PoseC3D's NTU-60 keypoint
  config (`configs/skeleton/posec3d/slowonly_r50_8xb16-u48-240e_ntu60-xsub-keypoint.py`), and on
  `skeleton_3d_ntu25.pkl` with ST-GCN's NTU-60 3-D joint config
  (`configs/skeleton/stgcn/stgcn_8xb16-joint-u100-80e_ntu60-xsub-keypoint-3d.py`), unchanged but
  for the file paths (and PyAV in place of decord for videos);
- `VideoDataset` on `{split}_list_videos.txt` with a TSN/SlowOnly-style pipeline decoding frames
  with PyAV;

for every split: every split must hold clips, every sample must come out of the pipeline with the
shapes the models take, and the labels must be the dataset's (`label_map.json`).

    run_mmaction.sh DATASET_DIR
"""

import json
import os
import sys

from mmengine.registry import DefaultScope

# Importing the datasets registers them and every transform. (`register_all_modules` would import
# the models too, and the PyPI wheel of mmaction2 1.2.0 lacks `models/localizers/drn`.)
from mmaction.datasets import PoseDataset, VideoDataset

DefaultScope.get_instance("check_mmaction", scope_name="mmaction")

LEFT_KP = [1, 3, 5, 7, 9, 11, 13, 15]
RIGHT_KP = [2, 4, 6, 8, 10, 12, 14, 16]

# PoseC3D (COCO-17 2-D keypoints → heatmap volumes), its train pipeline.
POSEC3D = [
    dict(type="UniformSampleFrames", clip_len=48),
    dict(type="PoseDecode"),
    dict(type="PoseCompact", hw_ratio=1.0, allow_imgpad=True),
    dict(type="Resize", scale=(-1, 64)),
    dict(type="RandomResizedCrop", area_range=(0.56, 1.0)),
    dict(type="Resize", scale=(56, 56), keep_ratio=False),
    dict(type="Flip", flip_ratio=0.5, left_kp=LEFT_KP, right_kp=RIGHT_KP),
    dict(type="GeneratePoseTarget", sigma=0.6, use_score=True, with_kp=True, with_limb=False),
    dict(type="FormatShape", input_format="NCTHW_Heatmap"),
    dict(type="PackActionInputs"),
]

# ST-GCN (NTU-25 3-D joints), its train pipeline.
STGCN = [
    dict(type="PreNormalize3D"),
    dict(type="GenSkeFeat", dataset="nturgb+d", feats=["j"]),
    dict(type="UniformSampleFrames", clip_len=100),
    dict(type="PoseDecode"),
    dict(type="FormatGCNInput", num_person=2),
    dict(type="PackActionInputs"),
]

# A video recognizer's train pipeline (SlowOnly/TSN style), PyAV for decoding.
VIDEO = [
    dict(type="PyAVInit"),
    dict(type="SampleFrames", clip_len=8, frame_interval=4, num_clips=1),
    dict(type="PyAVDecode"),
    dict(type="Resize", scale=(-1, 64)),
    dict(type="RandomResizedCrop"),
    dict(type="Resize", scale=(56, 56), keep_ratio=False),
    dict(type="Flip", flip_ratio=0.5),
    dict(type="FormatShape", input_format="NCTHW"),
    dict(type="PackActionInputs"),
]


def fail(msg):
    print(f"check_mmaction: FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def check(name, dataset, expected_shape, labels):
    if len(dataset) == 0:
        fail(f"{name}: no clips")
    seen = set()
    for i in range(len(dataset)):
        sample = dataset[i]
        shape = tuple(sample["inputs"].shape)
        if len(shape) != len(expected_shape) or any(
            want is not None and got != want for got, want in zip(shape, expected_shape)
        ):
            fail(f"{name} sample {i}: inputs {shape}, the model takes {expected_shape}")
        if float(sample["inputs"].float().std()) == 0.0:
            fail(f"{name} sample {i}: the inputs are blank (no keypoint or pixel reached them)")
        label = int(sample["data_samples"].gt_label.item())
        if label not in labels:
            fail(f"{name} sample {i}: label {label} is not in label_map.json {sorted(labels)}")
        seen.add(label)
    return len(dataset), shape, sorted(seen)


def main():
    if len(sys.argv) != 2:
        fail(__doc__.strip().splitlines()[-1])
    root = os.path.abspath(sys.argv[1])
    ann = os.path.join(root, "annotations")
    labels = set(json.load(open(os.path.join(ann, "label_map.json"), encoding="utf-8")).values())
    for split in ["train", "val", "test"]:
        results = []
        pose2d = PoseDataset(
            ann_file=os.path.join(ann, "skeleton_2d_coco17.pkl"), split=split, pipeline=POSEC3D
        )
        # N clips × 17 keypoint heatmaps × 48 frames × 56 × 56.
        results.append(("PoseC3D PoseDataset (2-D)", *check(f"{split} 2-D", pose2d, (1, 17, 48, 56, 56), labels)))
        pose3d = PoseDataset(
            ann_file=os.path.join(ann, "skeleton_3d_ntu25.pkl"), split=split, pipeline=STGCN
        )
        # N clips × 2 persons × 100 frames × 25 joints × 3 coordinates.
        results.append(("ST-GCN PoseDataset (3-D)", *check(f"{split} 3-D", pose3d, (1, 2, 100, 25, 3), labels)))
        videos = VideoDataset(
            ann_file=os.path.join(ann, f"{split}_list_videos.txt"),
            data_prefix=dict(video=root),
            pipeline=VIDEO,
        )
        results.append(("VideoDataset", *check(f"{split} videos", videos, (1, 3, 8, 56, 56), labels)))
        for name, n, shape, seen in results:
            print(f"ok {split}: {name}: {n} clips through the pipeline, inputs {shape}, labels {seen}")


if __name__ == "__main__":
    main()
