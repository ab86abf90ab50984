"""The beacon map after the survey: the fix record's reader and the self-survey
(`mfns map refine`, docs/self_survey.md)."""
