"""Stage 2, what each pixel sees: camera rays, the Embree binding, the ray
caster, the reference rasterizer and screen-space weights, all of which emit
one record, the hit buffer (:mod:`.hits`: triangle, model, barycentrics, t)."""
