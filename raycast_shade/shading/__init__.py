"""Stage 3, what colour each pixel is: the reflectance equation evaluated per
face (flat), per vertex (Gouraud) or per pixel (Phong) over a hit buffer, with
shadow rays, bump mapping and mirror reflections."""
