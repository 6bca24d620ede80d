/*
 * core/scene_internal.h — what scene documents (io/scene_doc.c) need beyond
 * the public scene API to edit a live scene holding a time-varying volume:
 * a sequence read into a candidate scene must move to the live scene (a
 * sequence has one owner), and a time step must be checked against the live
 * scene's sequence without changing it.
 */
#ifndef VOLUX_SCENE_INTERNAL_H
#define VOLUX_SCENE_INTERNAL_H

#include "volux/scene.h"

/* Hands the scene's sequence to the caller (NULL for a single volume). The
 * scene keeps the current step's volume as a single volume (time step 0 of
 * 1); no version is bumped (the image does not change). */
volux_sequence *volux_scene_take_sequence(volux_scene *s);

/* VOLUX_OK if `step` is a time step of the scene, else VOLUX_ERR_INVALID
 * with the message volux_scene_set_time_step gives for it. */
volux_status volux_scene_check_time_step(const volux_scene *s, int step);

/* The volume techniques render: the scene's volume, or its clipped copy
 * when the scene has a clip (volux_scene_set_clip, core/clip.c). */
volux_volume *volux_scene_render_volume(const volux_scene *s);

#endif
