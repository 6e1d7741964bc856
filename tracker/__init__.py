"""Frames in, marker tracks out: reading video, finding colour markers, the frame loop."""
