/*
 * volux/edit.h — the canonical scene edits, in one list: `volux bench
 * --edit KIND` times them, the technique × edit test matrix checks every
 * technique against every one of them, and front ends may offer them.
 *
 * Each edit is a real change of one scene aspect (its `touches` bits, see
 * volux_change). Calling an edit with k = 0, 1, 2, ... alternates between
 * two states where it can (odd calls undo even ones), so repeated
 * benchmark iterations keep measuring real work and the scene stays in its
 * neighbourhood (`time_step` on a sequence plays it forward instead, as an
 * animation does). Edits use only the public scene API, plus a mirrored
 * copy of the volume for `time_step` on a single volume.
 *
 * DOES NOT: update techniques (volux_technique_update / volux_render do).
 *
 * STEP BY STEP
 *     const volux_edit *e = volux_edit_find("tf");
 *     for (int k = 0; k < 10; k++) {
 *         volux_edit_apply(e, scene, k);        // the scene changes
 *         volux_technique_update(t, scene, NULL); // time this
 *     }
 */
#ifndef VOLUX_EDIT_H
#define VOLUX_EDIT_H

#include "base.h"
#include "scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct volux_edit {
    const char *name;      /* "tf", "camera", ... (bench metric update_ms.<name>) */
    const char *doc;       /* one line                                        */
    uint32_t touches;      /* volux_change bits the edit bumps                */
    const char *technique; /* NULL: any; else the only technique it applies to */
    int visible;           /* 1: changes the image of every technique that does
                              not ignore `touches`; 0: no claim (a rebuild of
                              the same state, for benchmarks)                  */
    /* Applies the k-th call to the scene. VOLUX_ERR_UNSUPPORTED when the
     * scene has nothing to edit (e.g. no light) or the edit belongs to
     * another technique; other failures are the setters'. */
    volux_status (*apply)(volux_scene *s, int k);
} volux_edit;

VOLUX_API int volux_edit_count(void);
VOLUX_API const volux_edit *volux_edit_at(int index);        /* NULL past the end */
VOLUX_API const volux_edit *volux_edit_find(const char *name); /* NULL if unknown  */
/* e->apply(s, k), with a message naming the edit on failure. */
VOLUX_API volux_status volux_edit_apply(const volux_edit *e, volux_scene *s, int k);

#ifdef __cplusplus
}
#endif
#endif
