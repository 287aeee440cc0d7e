"""Stage 3, what colour each pixel is: the reflectance equation evaluated per
face (flat), per vertex (Gouraud) or per pixel (Phong) over a hit buffer, with
shadow rays, bump mapping and mirror reflections.

Modules, lowest first: :mod:`.jit` (compile flags and the registries of
compile-time variants), :mod:`.records` (the helpers' records and 3-vectors),
:mod:`.shadows`, :mod:`.reflectance` (one function per reflectance model),
:mod:`.illumination` (the reflectance equation, every light kind),
:mod:`.surface` (geometry at a hit), :mod:`.bump`, :mod:`.inputs` (the
frame's packed kernel arguments, prepared once), the kernel families :mod:`.flat`, :mod:`.gouraud`,
:mod:`.phong`, then :mod:`.shade` (the public :func:`shade`),
:mod:`.normals`, :mod:`.mirrors` and :mod:`.conventions`.
"""
