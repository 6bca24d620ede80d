/* volux/volux.h — umbrella header: everything a client needs. */
#ifndef VOLUX_VOLUX_H
#define VOLUX_VOLUX_H

#include "base.h"
#include "version.h"
#include "ambient.h"
#include "camera.h"
#include "denoise.h"
#include "edit.h"
#include "image.h"
#include "io.h"
#include "light.h"
#include "render.h"
#include "scene.h"
#include "sequence.h"
#include "technique.h"
#include "transfer.h"
#include "volume.h"

#endif
