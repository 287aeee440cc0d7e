"""Stage 3, what colour each pixel is: the reflectance equation evaluated per
face (flat), per vertex (Gouraud) or per pixel (Phong) over a hit buffer, with
shadow rays, bump mapping and mirror reflections.

Modules, lowest first: :mod:`.jit` (compile flags and the spec/attenuation
variants), :mod:`.shadows`, :mod:`.illumination` (the reflectance equation),
:mod:`.surface` (geometry at a hit), :mod:`.bump`, :mod:`.inputs` (the
packed kernel arguments), the kernel families :mod:`.flat`, :mod:`.gouraud`,
:mod:`.phong`, then :mod:`.shade` (the public :func:`shade`),
:mod:`.normals`, :mod:`.mirrors` and :mod:`.conventions`.
"""
