"""Skeletal motion files: BVH, ASF/AMC, Xsens MVNX, and the action labels of a take."""
