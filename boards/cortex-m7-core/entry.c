/* entry.c -- the image entry of the Cortex-M7 size build. The portable core is
 * linked whole (--whole-archive, no section GC) so the image size is the size
 * of all of it; this entry only gives the linker a start symbol. */
void mfns_core_entry(void) __attribute__((noreturn, section(".text.mfns_core_entry")));
void mfns_core_entry(void)
{
    for (;;) {
    }
}
