import { describe, expect, it } from 'vitest';
import { tokenizeLine } from './wrl-language';

const styles = (line: string) => tokenizeLine(line).map(([t, s]) => `${t}:${s}`);

describe('wrl tokenizer', () => {
  it('highlights statements, constructors, numbers and comments', () => {
    expect(styles("MOVEP POSE(250, 100, 20, 30), L   ' elbow left")).toEqual([
      'MOVEP:keyword',
      'POSE:variableName.standard',
      '(:paren',
      '250:number',
      ',:separator',
      '100:number',
      ',:separator',
      '20:number',
      ',:separator',
      '30:number',
      '):paren',
      ',:separator',
      'L:atom',
      "' elbow left:lineComment",
    ]);
  });

  it('is case-insensitive and tells control keywords, operators and booleans', () => {
    expect(styles('if n <= 3 and not In(4) then')).toEqual([
      'if:controlKeyword',
      'n:variableName',
      '<=:compareOperator',
      '3:number',
      'and:logicOperator',
      'not:logicOperator',
      'In:variableName.standard',
      '(:paren',
      '4:number',
      '):paren',
      'then:controlKeyword',
    ]);
    expect(styles('X = TRUE')).toEqual(['X:variableName', '=:compareOperator', 'TRUE:bool']);
  });

  it('reads strings with doubled quotes and unclosed strings', () => {
    expect(styles('PRINT "say ""hi""", 1')).toEqual(['PRINT:keyword', '"say ""hi""":string', ',:separator', '1:number']);
    expect(styles('PRINT "open')).toEqual(['PRINT:keyword', '"open:string']);
  });

  it('reads numbers with fractions and exponents', () => {
    expect(styles('A = .5 + 1e3 - 2.5E-3')).toEqual([
      'A:variableName',
      '=:compareOperator',
      '.5:number',
      '+:arithmeticOperator',
      '1e3:number',
      '-:arithmeticOperator',
      '2.5E-3:number',
    ]);
  });

  it('marks fields, SUB definitions, CALLs and bad characters', () => {
    expect(styles('PRINT P.X, HERE().YAW')).toEqual([
      'PRINT:keyword',
      'P:variableName',
      '.:punctuation',
      'X:propertyName',
      ',:separator',
      'HERE:variableName.standard',
      '(:paren',
      '):paren',
      '.:punctuation',
      'YAW:propertyName',
    ]);
    expect(styles('SUB grip')).toEqual(['SUB:controlKeyword', 'grip:variableName.definition']);
    expect(styles('CALL grip')).toEqual(['CALL:controlKeyword', 'grip:variableName.function']);
    expect(styles('X = 1 ; Y')).toContain(';:invalid');
  });

  it('does not take L as a posture outside MOVEP', () => {
    expect(styles('L = 3')).toEqual(['L:variableName', '=:compareOperator', '3:number']);
  });

  it('reads the structured statements, declarations and names ending in $', () => {
    expect(styles('TRY')).toEqual(['TRY:controlKeyword']);
    expect(styles('CATCH 212')).toEqual(['CATCH:controlKeyword', '212:number']);
    expect(styles('DIM slots[25] AS NUMBER')).toEqual([
      'DIM:controlKeyword',
      'slots:variableName.definition',
      '[:squareBracket',
      '25:number',
      ']:squareBracket',
      'AS:controlKeyword',
      'NUMBER:typeName',
    ]);
    expect(styles('LOCAL k = n MOD 3')).toEqual([
      'LOCAL:controlKeyword',
      'k:variableName.definition',
      '=:compareOperator',
      'n:variableName',
      'MOD:logicOperator',
      '3:number',
    ]);
    expect(styles('FUNCTION twice(x)')).toEqual(['FUNCTION:controlKeyword', 'twice:variableName.definition', '(:paren', 'x:variableName', '):paren']);
    expect(styles('CALL PROGRAM "other"')).toEqual(['CALL:controlKeyword', 'PROGRAM:controlKeyword', '"other":string']);
    expect(styles('id$ = WAFER$("LP1", 1)')).toEqual([
      'id$:variableName',
      '=:compareOperator',
      'WAFER$:variableName.standard',
      '(:paren',
      '"LP1":string',
      ',:separator',
      '1:number',
      '):paren',
    ]);
  });

  it('reads the new motion and cell statements with their options', () => {
    expect(styles('MOVEL P SPEED 20 BLEND 5')).toEqual([
      'MOVEL:keyword',
      'P:variableName',
      'SPEED:keyword',
      '20:number',
      'BLEND:keyword',
      '5:number',
    ]);
    expect(styles('WAIT OPERATOR "ready?"')).toEqual(['WAIT:keyword', 'OPERATOR:keyword', '"ready?":string']);
    expect(styles('GET "LP1", n, B')).toEqual(['GET:keyword', '"LP1":string', ',:separator', 'n:variableName', ',:separator', 'B:atom']);
    expect(styles('SELECT CASE ERR')).toEqual(['SELECT:controlKeyword', 'CASE:controlKeyword', 'ERR:variableName.standard']);
    expect(styles('DO')).toEqual(['DO:controlKeyword']);
    expect(styles('LOOP UNTIL n > 3')).toEqual(['LOOP:controlKeyword', 'UNTIL:controlKeyword', 'n:variableName', '>:compareOperator', '3:number']);
  });
});
