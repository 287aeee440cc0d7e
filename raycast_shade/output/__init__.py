"""Stage 4, the result: the frame (image and buffers), tone mapping and image files."""
