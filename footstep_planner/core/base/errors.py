"""The base of every expected problem: bad files, rigs, clips, settings. Its message names
the file, object, bone or clip at fault; the CLI and the operators show it without a
traceback."""


class FootstepError(ValueError):
    pass
