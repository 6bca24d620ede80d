/*
 * core/name_guess.h — "did you mean" for names a user typed: technique and
 * parameter names (render/technique.c), scene keys (io/json_reader.c).
 */
#ifndef VOLUX_CORE_NAME_GUESS_H
#define VOLUX_CORE_NAME_GUESS_H

/* Feed every valid name to volux_name_guess_try, then
 * volux_name_guess_best gives the closest one when it is close enough to
 * be a typo of `name` (Levenshtein distance ≤ 2 for short names, about a
 * third of the length for long ones; a valid name that `name` begins,
 * from two letters on, counts as distance 1: "path" → "pathtrace"), else
 * NULL. */
typedef struct volux_name_guess {
    const char *best;
    int distance;
} volux_name_guess;
void volux_name_guess_try(volux_name_guess *g, const char *name, const char *candidate);
const char *volux_name_guess_best(const volux_name_guess *g, const char *name);

#endif
