  // Palpa, section IV: deform this vertex before VTK uses it.
  {
    vec4 palpaStreamValue = palpaFetchStream();
    palpaDeformPosition(palpaStreamValue);
#ifdef PALPA_DEFORM_NORMAL
    palpaDeformNormal(palpaStreamValue);
#endif
  }
